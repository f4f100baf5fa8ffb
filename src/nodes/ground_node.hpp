// `ridgeline ground`: the ground station as a node of the distributed swarm (issue 7, part 2).
// It publishes every UAV's reference plan (the global planner's r_i(t), transient local, so
// late agents get it), watches the world's clock, measurements and the agents' answers, and
// when the world declares a UAV lost:
//  - relays the lost UAV's position to the team as a stationary prediction (its autopilot
//    holds position; the agents' neighbour rows and yielding rule then keep clear of it);
//  - re-allocates the targets still open — the lost UAV's and the survivors' — over the
//    surviving UAVs from their current positions (target allocation and initial paths of the
//    global planner, without the joint optimizer, so it answers in well under a second), and
//    publishes each survivor's new plan as a newer version with times shifted to now.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "mission/scenario.hpp"
#include "planning/global_planner.hpp"
#include "transport_dds/dds_participant.hpp"
#include "world/terrain.hpp"

namespace ridgeline::nodes {

struct GroundNodeOptions {
  bool reallocate = true;
  double silence_timeout_s = 120.0;  ///< wall time without a clock tick (after the first)
  double start_timeout_s = 120.0;    ///< wall time to wait for the world's first tick
};

/// One re-allocation after a lost UAV.
struct Reallocation {
  double t_s = 0.0;
  std::string lost_uav;
  std::vector<std::string> open_targets;  ///< targets still open when it was lost
  std::string status;                     ///< "planned" or the planner's failure
  std::vector<std::pair<std::string, std::vector<std::string>>> assignment;  ///< UAV → targets
  double plan_time_s = 0.0;
};

struct GroundNodeResult {
  std::vector<Reallocation> reallocations;
  long long rejected = 0;
  bool world_stopped = false;
  std::string message;
};

/// The plan messages (version 0) of a global plan: UAVs without a plan entry hold at their
/// start.
GroundNodeResult run_ground_node(const mission::Scenario& scenario,
                                 std::shared_ptr<const world::Terrain> terrain,
                                 const planning::GlobalPlan& plan,
                                 const transport_dds::DdsOptions& dds,
                                 const GroundNodeOptions& options);

}  // namespace ridgeline::nodes
