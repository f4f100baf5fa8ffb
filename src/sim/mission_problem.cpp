#include "sim/mission_problem.hpp"

namespace ridgeline::sim {

planning::GlobalPlanningProblem make_planning_problem(
    const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain) {
  planning::GlobalPlanningProblem problem;
  problem.terrain = std::move(terrain);
  problem.area.min_m = Vec2(scenario.area.x_min_m, scenario.area.y_min_m);
  problem.area.max_m = Vec2(scenario.area.x_max_m, scenario.area.y_max_m);
  problem.min_altitude_m = scenario.altitude.min_m;
  problem.max_altitude_m = scenario.altitude.max_m;
  problem.terrain_clearance_m = scenario.safety.terrain_clearance_m;
  problem.separation_m = scenario.safety.separation_m;
  for (const UavSpec& u : scenario.uavs)
    problem.uavs.push_back({u.name, u.start_position_m, u.start_heading_rad, u.vehicle});
  for (const InspectionTarget& t : scenario.targets)
    problem.targets.push_back({t.name, t.position_m, t.priority});
  return problem;
}

planning::GlobalPlannerOptions make_planner_options(const Scenario& scenario) {
  planning::GlobalPlannerOptions options;
  options.timing.control_period_s = scenario.mpc.control_period_s;
  return options;
}

}  // namespace ridgeline::sim
