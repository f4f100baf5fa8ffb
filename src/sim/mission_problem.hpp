// From a scenario to the global planner's problem and options (DESIGN §5 inputs): the bridge
// between the scenario's values and the planning layer, which knows nothing of scenarios.
#pragma once

#include <memory>

#include "planning/global_planner.hpp"
#include "sim/scenario.hpp"

namespace ridgeline::sim {

planning::GlobalPlanningProblem make_planning_problem(
    const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain);

planning::GlobalPlannerOptions make_planner_options(const Scenario& scenario);

}  // namespace ridgeline::sim
