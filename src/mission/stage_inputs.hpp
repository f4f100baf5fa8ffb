// From a scenario to each stage's inputs: the global planner's problem and options (DESIGN §5),
// the tracker's and the agent's options (§3, §4). The bridge between the scenario's values and
// the layers below, which know nothing of scenarios. The safety limits are not among the
// options: every stage takes the scenario's SafetyLimits (Scenario::safety) as an argument.
#pragma once

#include <memory>

#include "mission/scenario.hpp"
#include "mpc/uav_tracker.hpp"
#include "planning/global_planner.hpp"
#include "swarm/agent.hpp"

namespace ridgeline::mission {

planning::GlobalPlanningProblem make_planning_problem(
    const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain);

planning::GlobalPlannerOptions make_planner_options(const Scenario& scenario);

/// The tracker's options for a UAV from the scenario's mpc block.
mpc::UavTrackerOptions make_tracker_options(const Scenario& scenario, const UavSpec& uav);

/// The agent's options for UAV `index` with its targets from the plan.
swarm::AgentOptions make_agent_options(const Scenario& scenario, int index,
                                       const planning::UavPlan& plan);

}  // namespace ridgeline::mission
