// Comparison method [8] on board (issue 11): a DDPG policy (learning/ddpg.hpp) steers the UAV
// directly, with no reference trajectory and no MPC. Every decision period of the policy
// (the action period it was trained with, 0.4 s) the agent builds the same observation as
// the training environment (learning::make_observation) from its position fix, its filtered
// anemometer reading, its current target (its allocated targets in visiting order, as every
// method), the threats it sensed itself and its neighbours' broadcast positions (obstacles of
// radius d_safe: "the others as moving obstacles"), and holds the policy's command
// (learning::action_to_command; the climb within 90 % of the pitch limit at the current
// speed, as the pursuit follower, since a slowing UAV would otherwise pitch beyond θ_max) until
// the next decision. Neighbours count as obstacles only within kNeighbourRange_m. The shared agent
// machinery (BaselineAgent) applies the same command-rate and maneuver limits as every other
// method.
//
// The timed reference it is given (the [7] A* plan of the same allocation, sim/method.hpp) is
// not followed: it only times the mission (a target still open 30 s after the reference's end
// is missed) and is what the tracking error is measured against.
#pragma once

#include <memory>

#include "baselines/baseline_agent.hpp"
#include "learning/ddpg.hpp"

namespace ridgeline::baselines {

class DdpgAgent final : public BaselineAgent {
 public:
  /// A neighbour is an obstacle of the observation only within this surface distance.
  static constexpr double kNeighbourRange_m = 40.0;

  /// Throws InputError when `policy` is null.
  DdpgAgent(const BaselineAgentOptions& options, const world::SafetyLimits& limits,
            std::shared_ptr<const learning::DdpgPolicy> policy,
            std::shared_ptr<const mpc::SampledReference> reference,
            std::shared_ptr<const world::Terrain> terrain);

  /// The observation the policy would get now (for tests and diagnostics).
  learning::Observation observe(double t_s, const vehicle::State& state,
                                const Vec3& wind_m_s) const;

 protected:
  vehicle::Input compute(double t_s, const vehicle::State& state, const Vec3& wind_m_s,
                         std::vector<Vec3>& prediction) override;

 private:
  std::shared_ptr<const learning::DdpgPolicy> policy_;
  double next_decision_s_ = -1e9;
  vehicle::Input held_ = vehicle::Input::Zero();
};

}  // namespace ridgeline::baselines
