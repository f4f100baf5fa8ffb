#include "mission/stage_inputs.hpp"

#include <algorithm>

namespace ridgeline::mission {

planning::GlobalPlanningProblem make_planning_problem(
    const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain) {
  planning::GlobalPlanningProblem problem;
  problem.terrain = std::move(terrain);
  problem.area.min_m = Vec2(scenario.area.x_min_m, scenario.area.y_min_m);
  problem.area.max_m = Vec2(scenario.area.x_max_m, scenario.area.y_max_m);
  problem.limits = scenario.safety;
  for (const InspectionTarget& t : scenario.targets)
    problem.targets.push_back({t.name, t.position_m, t.priority});
  for (const UavSpec& u : scenario.uavs) {
    planning::PlannerUav pu{u.name, u.start_position_m, u.start_heading_rad, u.vehicle,
                            {},     u.end_position_m};
    for (const std::string& name : u.assigned_targets) {
      // validate() has checked that the name exists; an unknown one is skipped, never guessed.
      const auto it = std::find_if(scenario.targets.begin(), scenario.targets.end(),
                                   [&](const InspectionTarget& t) { return t.name == name; });
      if (it != scenario.targets.end())
        pu.required_targets.push_back(static_cast<int>(it - scenario.targets.begin()));
    }
    problem.uavs.push_back(std::move(pu));
  }
  return problem;
}

planning::GlobalPlannerOptions make_planner_options(const Scenario& scenario) {
  planning::GlobalPlannerOptions options;
  options.timing.control_period_s = scenario.mpc.control_period_s;
  // Stage 3 (eq. 14–24) with the scenario's grid, penalties and weights.
  const PlannerConfig& p = scenario.planner;
  planning::TrajectoryOptimizerOptions& o = options.optimizer;
  o.waypoints_per_uav = p.waypoints_per_uav;
  o.max_turn_angle_rad = p.max_turn_angle_rad;
  o.pitch_penalty = p.pitch_penalty;
  o.turn_penalty = p.turn_penalty;
  o.weight_range = p.weight_range;
  o.weight_pitch = p.weight_pitch;
  o.weight_turn = p.weight_turn;
  o.weight_altitude = p.weight_altitude;
  o.lambda_individual = p.lambda_individual;
  o.lambda_collision = p.lambda_collision;
  options.allocation.makespan_weight = p.allocation_makespan_weight;
  options.allocation.priority_weight = p.allocation_priority_weight;
  return options;
}

mpc::UavTrackerOptions make_tracker_options(const Scenario& scenario, const UavSpec& uav) {
  const MpcConfig& m = scenario.mpc;
  mpc::UavTrackerOptions o;
  o.vehicle = uav.vehicle;
  o.control_period_s = m.control_period_s;
  o.prediction_step_s = m.prediction_step_s;
  o.prediction_horizon = m.horizon_steps;
  o.control_horizon = m.control_horizon_steps;
  o.weight_xy_per_m2 = m.position_weight;
  o.weight_z_per_m2 = m.position_weight;
  o.weight_speed_move = m.move_weights[0];
  o.weight_turn_move = m.move_weights[1];
  o.weight_climb_move = m.move_weights[2];
  o.max_speed_cmd_rate_m_s2 = m.max_moves[0] / m.prediction_step_s;
  o.max_turn_cmd_rate_rad_s2 = m.max_moves[1] / m.prediction_step_s;
  o.max_climb_cmd_rate_m_s2 = m.max_moves[2] / m.prediction_step_s;
  o.slack_linear_weight = m.slack_weight;
  // The anemometer's error: 3σ of its noise bounds it with 99.7 % per component.
  o.wind_error_bound_m_s = std::max(0.1, 3.0 * scenario.wind.measurement_noise_m_s);
  o.max_threats = std::max<int>(4, static_cast<int>(scenario.threats.size()));
  o.max_neighbours = std::clamp<int>(static_cast<int>(scenario.uavs.size()) - 1, 1, 8);
  return o;
}

swarm::AgentOptions make_agent_options(const Scenario& scenario, int index,
                                       const planning::UavPlan& plan) {
  const UavSpec& uav = scenario.uavs[static_cast<std::size_t>(index)];
  swarm::AgentOptions o;
  o.id = index;
  o.num_uavs = static_cast<int>(scenario.uavs.size());
  o.tracker = make_tracker_options(scenario, uav);
  for (const int k : plan.targets) {
    const InspectionTarget& t = scenario.targets.at(static_cast<std::size_t>(k));
    o.targets.push_back({t.name, t.position_m, t.inspection_radius_m, t.inspection_radius_m});
  }
  o.fly_to_end = uav.end_position_m.has_value();
  o.end_radius_m = end_reached_radius_m();
  o.broadcast_period_s = 1.0 / scenario.simulation.message_rate_hz;
  o.detour.max_climb_rate_m_s = uav.vehicle.max_climb_rate_m_s;
  o.optimizer_replan = scenario.planner.optimizer_replan;
  return o;
}

}  // namespace ridgeline::mission
