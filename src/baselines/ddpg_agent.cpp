#include "baselines/ddpg_agent.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace ridgeline::baselines {

DdpgAgent::DdpgAgent(const BaselineAgentOptions& options, const world::SafetyLimits& limits,
                     std::shared_ptr<const learning::DdpgPolicy> policy,
                     std::shared_ptr<const mpc::SampledReference> reference,
                     std::shared_ptr<const world::Terrain> terrain)
    : BaselineAgent(options, limits, std::move(reference), std::move(terrain)),
      policy_(std::move(policy)) {
  if (!policy_) throw InputError("ddpg_model", "a DDPG policy is required for method ddpg");
  held_ = last_command();
}

learning::Observation DdpgAgent::observe(double t_s, const vehicle::State& state,
                                         const Vec3& wind_m_s) const {
  const BaselineAgentOptions& o = options();
  learning::ObservationInput in;
  in.state = state;
  in.wind_m_s = wind_m_s;
  const int next = std::min(targets_inspected(), static_cast<int>(o.targets.size()) - 1);
  in.target_m =
      next >= 0 ? o.targets[static_cast<std::size_t>(next)].position_m : Vec3(state.head<3>());
  in.terrain = &terrain();
  in.limits = limits();
  for (const world::Threat& th : threats())
    in.obstacles.push_back({th.centre_at(t_s), th.velocity_m_s, th.radius_m});
  for (const Neighbour& n : neighbours()) {
    // Only a neighbour within kNeighbourRange_m is an obstacle: the policy was trained on
    // obstacles that come and go, not on team-mates that fly beside it for the whole mission.
    if ((n.at(t_s) - state.head<3>()).norm() - limits().separation_m > kNeighbourRange_m) continue;
    const auto& pts = n.prediction.positions_m;
    const Vec3 velocity = pts.size() >= 2
                              ? Vec3((pts.back() - pts.front()) /
                                     (n.prediction.step_s * static_cast<double>(pts.size() - 1)))
                              : Vec3::Zero();
    in.obstacles.push_back({n.at(t_s), velocity, limits().separation_m});
  }
  return learning::make_observation(in, o.vehicle);
}

vehicle::Input DdpgAgent::compute(double t_s, const vehicle::State& state, const Vec3& wind_m_s,
                                  std::vector<Vec3>& prediction) {
  const BaselineAgentOptions& o = options();
  // Decide at the policy's own period (within half a control period), hold in between.
  if (t_s >= next_decision_s_ - 0.5 * o.control_period_s) {
    held_ =
        learning::action_to_command(policy_->act(observe(t_s, state, wind_m_s)), state, o.vehicle);
    // As the pursuit follower: the climb within 90 % of the pitch limit at the current speed,
    // room for the speed's lag (a slowing UAV would otherwise pitch beyond θ_max).
    const double climb_max =
        0.9 * std::max(state[vehicle::kV], 0.0) * std::tan(o.vehicle.max_pitch_rad);
    held_[vehicle::kClimbRateCmd] =
        std::clamp(held_[vehicle::kClimbRateCmd], -climb_max, climb_max);
    next_decision_s_ = t_s + policy_->action_period_s();
  }
  rollout(state, last_command(), held_, wind_m_s, o.prediction_step_s, o.prediction_steps,
          prediction);
  return held_;
}

}  // namespace ridgeline::baselines
