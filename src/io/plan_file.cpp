#include "io/plan_file.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "io/geo_frame.hpp"

namespace ridgeline::io {

nlohmann::json plan_to_json(const planning::GlobalPlan& plan, const mission::Scenario& scenario) {
  nlohmann::json j;
  j["scenario"] = scenario.name;
  j["status"] = std::string(planning::to_string(plan.status));
  j["solve_time_s"] = plan.total_time_s;
  j["stage_times_s"] = {{"allocation", plan.allocation_time_s},
                        {"initial_paths", plan.search_time_s},
                        {"optimization", plan.optimization_time_s},
                        {"time_parametrization", plan.timing_time_s},
                        {"validation", plan.validation_time_s}};
  j["path_source"] = std::string(planning::to_string(plan.path_source));
  if (!plan.optimizer_message.empty()) j["optimizer_message"] = plan.optimizer_message;
  double total_length = 0.0, makespan = 0.0;
  for (const planning::UavPlan& u : plan.uavs) {
    total_length += u.timing.path_length_m;
    makespan = std::max(makespan, u.timing.duration_s);
  }
  j["cost"] = {{"total_length_m", total_length},
               {"makespan_s", makespan},
               {"allocation_objective", plan.allocation.objective}};
  if (plan.optimization) {
    // Eq. 15–24 terms of the flown waypoints: the optimum, or the initial paths on the grid
    // when those are flown.
    const planning::TrajectoryResult& r = *plan.optimization;
    const bool optimized = plan.path_source == planning::PathSource::kOptimized;
    const std::vector<planning::UavCost>& costs = optimized ? r.costs : r.initial_costs;
    if (!costs.empty()) {
      auto terms = [](const planning::UavCost& c) {
        return nlohmann::json{{"range", c.range},           {"pitch", c.pitch},
                              {"pitch_penalty", c.pitch_penalty}, {"turn", c.turn},
                              {"turn_penalty", c.turn_penalty},   {"altitude", c.altitude},
                              {"total", c.total}};
      };
      planning::UavCost sum;
      nlohmann::json per_uav = nlohmann::json::array();
      for (std::size_t i = 0; i < costs.size(); ++i) {
        const planning::UavCost& c = costs[i];
        sum.range += c.range;
        sum.pitch += c.pitch;
        sum.pitch_penalty += c.pitch_penalty;
        sum.turn += c.turn;
        sum.turn_penalty += c.turn_penalty;
        sum.altitude += c.altitude;
        sum.total += c.total;
        nlohmann::json cj = terms(c);
        cj["id"] = i < plan.uavs.size() ? plan.uavs[i].name : std::string();
        per_uav.push_back(std::move(cj));
      }
      j["cost"]["evaluated_on"] = optimized ? "optimized waypoints" : "initial paths";
      j["cost"]["objective"] = optimized ? r.objective : r.initial_objective;       // J, eq. 24
      j["cost"]["collision"] = optimized ? r.collision_cost : r.initial_collision_cost;  // J_col
      j["cost"]["initial_objective"] = r.initial_objective;
      j["cost"]["terms"] = terms(sum);  // Σ_i of each J_i term, eq. 23
      j["cost"]["uavs"] = std::move(per_uav);
    }
    j["optimizer"] = {{"status", std::string(planning::to_string(r.status))},
                      {"message", r.message},
                      {"iterations", r.ipopt_iterations},
                      {"solves", r.solves},
                      {"priority_swaps", r.priority_swaps},
                      {"variables", r.variables},
                      {"constraints", r.constraints},
                      {"separation_rows", r.separation_rows},
                      {"time_step_s", r.time_step_s},
                      {"solve_time_s", r.solve_time_s},
                      {"total_time_s", r.total_time_s}};
  }
  // The frame, the targets and the threats, so that exports (io/geo_export.hpp) need nothing
  // but this file.
  if (scenario.origin) {
    const GeoFrame frame(*scenario.origin);
    j["frame"] = {{"origin",
                   {{"lat_deg", scenario.origin->lat_deg},
                    {"lon_deg", scenario.origin->lon_deg},
                    {"alt_amsl_m", scenario.origin->alt_amsl_m}}},
                  {"projection", frame.proj_definition()},
                  {"z", "metres above mean sea level"}};
  } else {
    j["frame"] = {{"origin", nullptr}, {"z", "metres in the terrain datum"}};
  }
  j["targets"] = nlohmann::json::array();
  for (const mission::InspectionTarget& t : scenario.targets) {
    j["targets"].push_back({{"name", t.name},
                            {"position_m", {t.position_m.x(), t.position_m.y(), t.position_m.z()}},
                            {"priority", t.priority},
                            {"inspection_radius_m", t.inspection_radius_m}});
  }
  j["threats"] = nlohmann::json::array();
  for (const world::Threat& t : scenario.threats) {
    j["threats"].push_back(
        {{"name", t.name},
         {"centre_m", {t.centre_m.x(), t.centre_m.y(), t.centre_m.z()}},
         {"velocity_m_s", {t.velocity_m_s.x(), t.velocity_m_s.y(), t.velocity_m_s.z()}},
         {"radius_m", t.radius_m},
         {"appear_s", t.appear_s},
         {"vanish_s", t.vanish_s}});
  }
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
    for (const mission::UavSpec& spec : scenario.uavs) {
      if (spec.name == u.name) uj["cruise_speed_m_s"] = spec.vehicle.cruise_speed_m_s;
    }
    uj["max_turn_rate_rad_s"] = u.timing.max_turn_rate_rad_s;
    uj["max_climb_rate_m_s"] = u.timing.max_climb_rate_m_s;
    j["uavs"].push_back(std::move(uj));
  }
  return j;
}

std::string plan_summary_text(const planning::GlobalPlan& plan, const mission::Scenario& scenario) {
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
      "altitude {:.0f}..{:.0f} m\npaths: {}{}\nplanned in {:.3f} s\n",
      plan.validation.min_terrain_clearance_m, scenario.safety.terrain_clearance_m,
      plan.validation.min_separation_m, scenario.safety.separation_m,
      plan.validation.min_altitude_m, plan.validation.max_altitude_m,
      planning::to_string(plan.path_source),
      plan.optimizer_message.empty() ? std::string() : " — " + plan.optimizer_message,
      plan.total_time_s);
  return out;
}

}  // namespace ridgeline::io
