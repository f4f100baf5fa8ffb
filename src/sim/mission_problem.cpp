#include "sim/mission_problem.hpp"

namespace ridgeline::sim {

planning::GlobalPlanningProblem make_planning_problem(
    const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain) {
  planning::GlobalPlanningProblem problem;
  problem.terrain = std::move(terrain);
  problem.area.min_m = Vec2(scenario.area.x_min_m, scenario.area.y_min_m);
  problem.area.max_m = Vec2(scenario.area.x_max_m, scenario.area.y_max_m);
  problem.limits = scenario.safety;
  for (const UavSpec& u : scenario.uavs)
    problem.uavs.push_back({u.name, u.start_position_m, u.start_heading_rad, u.vehicle});
  for (const InspectionTarget& t : scenario.targets)
    problem.targets.push_back({t.name, t.position_m, t.priority});
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

}  // namespace ridgeline::sim
