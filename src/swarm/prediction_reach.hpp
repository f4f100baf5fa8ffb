// How far the proposed agent's neighbours' predictions must travel at every broadcast
// (in_process_transport.hpp, PredictionReach; issue 20).
//
// An agent puts a neighbour in its MPC when it is within
//   R_mpc = 2·v_max·T_p + d_safe + separation_margin_m + max_age_margin_m + activation_distance_m
// of it plus v_max·age (swarm/agent.hpp, mpc_neighbour_reach_m: two UAVs farther apart cannot come
// within a row's activation distance in the horizon T_p). A participant beyond the transport's
// reach gets a prediction only every far period, so its predictions are up to
// far_period + latency + jitter + one broadcast period old, and the transport measures
// distances on positions up to a broadcast period old: the reach adds 2·v_max times all of
// that, so every neighbour the MPC may take gets every prediction as before. The look-aheads
// that re-plan once a second (conflicts, separation levels) see farther neighbours through the
// far copies.
#pragma once

#include "swarm/agent.hpp"
#include "swarm/in_process_transport.hpp"
#include "world/safety_limits.hpp"

namespace ridgeline::swarm {

/// The reach for a team of agents with `options` (the largest over them), `broadcast_period_s`
/// between broadcasts, on `link`. far_period_s: a quarter of the shortest neighbour_stale_s
/// (so no neighbour's prediction goes stale), at most 0.25 s.
PredictionReach prediction_reach(const std::vector<AgentOptions>& options,
                                 const world::SafetyLimits& limits, const LinkModel& link,
                                 double broadcast_period_s);

}  // namespace ridgeline::swarm
