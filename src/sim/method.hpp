// The methods a mission can be flown with (issue 6): the proposed method and the paper's
// comparison methods [7], [6] and [8] (src/baselines/, src/learning/). All of them are
// planned on the same scenario and flown through the same truth simulator, transport and
// metrics (mission.hpp); only the planner and the on-board agent differ.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "baselines/baseline_agent.hpp"
#include "learning/ddpg.hpp"
#include "mission/scenario.hpp"
#include "mpc/reference.hpp"
#include "planning/global_planner.hpp"
#include "swarm/uav_agent.hpp"

namespace ridgeline::sim {

enum class Method {
  kProposed,   ///< "proposed": joint Ipopt plan (eq. 14–24) + incremental MPC agents
  kAstarDwa,   ///< "astar_dwa": [7] improved A* + dynamic window
  kWindAware,  ///< "wind_aware": [6] wind-aware offline path + pure pursuit / PID
  /// "ddpg": [8] a DDPG policy steers each UAV to its targets (baselines/ddpg_agent.hpp); its
  /// ground-station step is [7]'s plan, used only for the allocation and as the reference the
  /// tracking error is measured against (the policy does not follow it).
  kDdpg,
};

/// "proposed", "astar_dwa", "wind_aware", "ddpg".
std::string_view to_string(Method method);
std::vector<Method> all_methods();

/// Parses a method name; throws InputError(field, "unknown method 'x' (one of ...)").
Method parse_method(std::string_view text, const std::string& field = "--method");

/// The method's ground-station plan for the scenario (never throws on bad data: see status).
planning::GlobalPlan plan_for_method(const mission::Scenario& scenario,
                                     std::shared_ptr<const world::Terrain> terrain, Method method);

/// The comparison agents' options for UAV `index` (baselines/baseline_agent.hpp).
baselines::BaselineAgentOptions make_baseline_agent_options(const mission::Scenario& scenario,
                                                            int index,
                                                            const planning::UavPlan& plan);

/// The on-board agent of `method` for UAV `index`, flying `reference` with the targets of
/// `plan`, held to the scenario's safety limits: the one place a method becomes an agent (the
/// DDS agent process flies only the proposed method, through mission::make_agent_options, so
/// it links none of the comparison methods). `ddpg_policy` is required for Method::kDdpg
/// (InputError naming --ddpg-model otherwise).
std::unique_ptr<swarm::UavAgent> make_agent(
    Method method, const mission::Scenario& scenario, int index, const planning::UavPlan& plan,
    std::shared_ptr<const mpc::SampledReference> reference,
    std::shared_ptr<const world::Terrain> terrain,
    std::shared_ptr<const learning::DdpgPolicy> ddpg_policy);

}  // namespace ridgeline::sim
