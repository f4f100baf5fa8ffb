#include "swarm/prediction_reach.hpp"

#include <algorithm>

namespace ridgeline::swarm {

PredictionReach prediction_reach(const std::vector<AgentOptions>& options,
                                 const world::SafetyLimits& limits, const LinkModel& link,
                                 double broadcast_period_s) {
  PredictionReach reach;
  if (options.empty()) return reach;
  reach.far_period_s = 0.25;
  for (const AgentOptions& o : options)
    reach.far_period_s = std::min(reach.far_period_s, 0.25 * o.neighbour_stale_s);
  double reach_m = 0.0;
  for (const AgentOptions& o : options) {
    const double v_max = o.tracker.vehicle.max_speed_m_s();
    const double mpc_m = mpc_neighbour_reach_m(o, limits);
    const double delay_s =
        reach.far_period_s + link.latency_s + link.jitter_s + 2.0 * broadcast_period_s;
    reach_m = std::max(reach_m, mpc_m + 2.0 * v_max * delay_s);
  }
  reach.reach_m = reach_m;
  return reach;
}

}  // namespace ridgeline::swarm
