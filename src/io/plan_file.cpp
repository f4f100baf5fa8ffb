#include "io/plan_file.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace ridgeline::io {

nlohmann::json plan_to_json(const planning::GlobalPlan& plan, const sim::Scenario& scenario) {
  nlohmann::json j;
  j["scenario"] = scenario.name;
  j["status"] = std::string(planning::to_string(plan.status));
  j["solve_time_s"] = plan.total_time_s;
  j["stage_times_s"] = {{"allocation", plan.allocation_time_s},
                        {"initial_paths", plan.search_time_s},
                        {"time_parametrization", plan.timing_time_s},
                        {"validation", plan.validation_time_s}};
  double total_length = 0.0, makespan = 0.0;
  for (const planning::UavPlan& u : plan.uavs) {
    total_length += u.timing.path_length_m;
    makespan = std::max(makespan, u.timing.duration_s);
  }
  j["cost"] = {{"total_length_m", total_length},
               {"makespan_s", makespan},
               {"allocation_objective", plan.allocation.objective}};
  j["validation"] = {{"min_terrain_clearance_m", plan.validation.min_terrain_clearance_m},
                     {"min_separation_m", plan.validation.min_separation_m},
                     {"min_altitude_m", plan.validation.min_altitude_m},
                     {"max_altitude_m", plan.validation.max_altitude_m},
                     {"max_pitch_deg", rad_to_deg(plan.validation.max_pitch_rad)},
                     {"samples_checked", plan.validation.samples_checked}};
  j["uavs"] = nlohmann::json::array();
  for (const planning::UavPlan& u : plan.uavs) {
    nlohmann::json uj;
    uj["id"] = u.name;
    uj["targets"] = nlohmann::json::array();
    for (int t : u.targets) uj["targets"].push_back(scenario.targets[static_cast<std::size_t>(t)].name);
    uj["waypoints"] = nlohmann::json::array();
    for (const Vec3& p : u.waypoints_m) uj["waypoints"].push_back({p.x(), p.y(), p.z()});
    uj["reference"] = nlohmann::json::array();
    for (std::size_t k = 0; k < u.timing.samples.size(); ++k) {
      const Vec3& p = u.timing.samples[k].position_m;
      uj["reference"].push_back({u.timing.sample_times_s[k], p.x(), p.y(), p.z()});
    }
    uj["length_m"] = u.timing.path_length_m;
    uj["duration_s"] = u.timing.duration_s;
    uj["max_turn_rate_rad_s"] = u.timing.max_turn_rate_rad_s;
    uj["max_climb_rate_m_s"] = u.timing.max_climb_rate_m_s;
    j["uavs"].push_back(std::move(uj));
  }
  return j;
}

std::string plan_summary_text(const planning::GlobalPlan& plan, const sim::Scenario& scenario) {
  std::string out = fmt::format("{:<10} {:<24} {:>9} {:>9}\n", "uav", "targets", "length m",
                                "time s");
  for (const planning::UavPlan& u : plan.uavs) {
    std::string targets;
    for (int t : u.targets) {
      if (!targets.empty()) targets += ",";
      targets += scenario.targets[static_cast<std::size_t>(t)].name;
    }
    out += fmt::format("{:<10} {:<24} {:>9.0f} {:>9.1f}\n", u.name, targets,
                       u.timing.path_length_m, u.timing.duration_s);
  }
  out += fmt::format(
      "validated: min terrain clearance {:.1f} m (h_safe {}), min separation {:.1f} m (d_safe {}), "
      "altitude {:.0f}..{:.0f} m\nplanned in {:.3f} s\n",
      plan.validation.min_terrain_clearance_m, scenario.safety.terrain_clearance_m,
      plan.validation.min_separation_m, scenario.safety.separation_m,
      plan.validation.min_altitude_m, plan.validation.max_altitude_m, plan.total_time_s);
  return out;
}

}  // namespace ridgeline::io
