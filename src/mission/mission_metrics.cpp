#include "mission/mission_metrics.hpp"

#include <fmt/format.h>

#include <cmath>

namespace ridgeline::mission {
namespace {

/// JSON has no infinity: "never came close" (one UAV, no threat) is written as null.
nlohmann::json finite_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

}  // namespace

int MissionMetrics::total_constraint_violations() const {
  int total = 0;
  for (const auto& [kind, count] : constraint_violations) total += count;
  return total;
}

bool MissionMetrics::safe() const {
  return terrain_collisions == 0 && threat_intrusions == 0 && separation_violations == 0 &&
         total_constraint_violations() == 0;
}

nlohmann::json to_json(const MissionMetrics& m) {
  nlohmann::json uavs = nlohmann::json::array();
  for (const UavMetrics& u : m.uavs) {
    uavs.push_back({{"name", u.name},
                    {"path_length_m", u.path_length_m},
                    {"tracking_rmse_m", u.tracking_rmse_m},
                    {"tracking_mse_m2", u.tracking_mse_m2},
                    {"tracking_samples", u.tracking_samples},
                    {"min_terrain_clearance_m", finite_or_null(u.min_terrain_clearance_m)},
                    {"targets_assigned", u.targets_assigned},
                    {"targets_inspected", u.targets_inspected},
                    {"missed_targets", u.missed_targets},
                    {"finished", u.finished},
                    {"finish_time_s", u.finish_time_s},
                    {"end_distance_m", finite_or_null(u.end_distance_m)},
                    {"end_reached", u.end_reached},
                    {"replans", u.replans},
                    {"optimizer_replans", u.optimizer_replans},
                    {"neighbour_conflicts", u.neighbour_conflicts},
                    {"replan_failures", u.replan_failures},
                    {"rejoins", u.rejoins},
                    {"level_changes", u.level_changes},
                    {"delay_changes", u.delay_changes},
                    {"reapproaches", u.reapproaches},
                    {"guard_steps", u.guard_steps},
                    {"fallback_steps", u.fallback_steps},
                    {"qp_failures", u.qp_failures},
                    {"stale_neighbour_steps", u.stale_neighbour_steps},
                    {"messages_rejected", u.messages_rejected},
                    {"max_slack_m", u.max_slack_m}});
  }
  return {{"uavs", uavs},
          {"min_separation_m", finite_or_null(m.min_separation_m)},
          {"min_separation_between",
           m.min_separation_pair.first >= 0 && m.min_separation_pair.second >= 0 &&
                   static_cast<std::size_t>(m.min_separation_pair.second) < m.uavs.size()
               ? nlohmann::json::array(
                     {m.uavs[static_cast<std::size_t>(m.min_separation_pair.first)].name,
                      m.uavs[static_cast<std::size_t>(m.min_separation_pair.second)].name})
               : nlohmann::json(nullptr)},
          {"min_separation_time_s", m.min_separation_pair.first >= 0
                                        ? nlohmann::json(m.min_separation_time_s)
                                        : nlohmann::json(nullptr)},
          {"min_threat_distance_m", finite_or_null(m.min_threat_distance_m)},
          {"threat_encounters", m.threat_encounters},
          {"threat_intrusions", m.threat_intrusions},
          {"threat_intrusions_unavoidable", m.unavoidable_intrusions},
          {"threat_intrusions_avoidable", m.avoidable_intrusions},
          {"unavoidable_intrusion_contact_s", m.unavoidable_intrusion_contact_s},
          {"threat_margin_violations", m.threat_margin_violations},
          {"avoidance_success_rate", m.avoidance_success_rate},
          {"terrain_collisions", m.terrain_collisions},
          {"separation_violations", m.separation_violations},
          {"constraint_violations", m.constraint_violations},
          {"min_turn_radius_m", finite_or_null(m.min_turn_radius_m)},
          {"max_turn_command_ratio", m.max_turn_command_ratio},
          {"mpc_solve_us", to_json(m.mpc_solve_us)},
          {"mpc_solve_cpu_us", to_json(m.mpc_solve_cpu_us)},
          {"qp_iterations", to_json(m.qp_iterations)},
          {"global_plan_s", m.global_plan_s},
          {"sim_time_s", m.sim_time_s},
          {"wall_time_s", m.wall_time_s},
          {"real_time_factor", m.wall_time_s > 0.0 ? m.sim_time_s / m.wall_time_s : 0.0},
          {"cpu_time_s", m.cpu_time_s},
          {"real_time_factor_cpu", m.cpu_time_s > 0.0 ? m.sim_time_s / m.cpu_time_s : 0.0},
          {"messages_published", m.messages_published},
          {"messages_dropped", m.messages_dropped},
          {"mission_complete", m.mission_complete},
          {"safe", m.safe()}};
}

std::string trajectories_csv(const std::vector<TrajectoryRow>& rows, const Scenario& scenario) {
  std::string out = "t,uav,x,y,z,ref_x,ref_y,ref_z,v,psi,w\n";
  out.reserve(rows.size() * 96);
  for (const TrajectoryRow& r : rows) {
    out += fmt::format("{:.2f},{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.4f},{:.3f}\n",
                       r.t_s, scenario.uavs[static_cast<std::size_t>(r.uav)].name, r.position_m.x(),
                       r.position_m.y(), r.position_m.z(), r.reference_m.x(), r.reference_m.y(),
                       r.reference_m.z(), r.speed_m_s, r.heading_rad, r.climb_rate_m_s);
  }
  return out;
}

}  // namespace ridgeline::mission
