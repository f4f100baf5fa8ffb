#include "baselines/ddpg_agent.hpp"

#include "core/error.hpp"

namespace ridgeline::baselines {

DdpgAgent::DdpgAgent(const BaselineAgentOptions& options,
                     std::shared_ptr<const learning::DdpgPolicy> policy,
                     std::shared_ptr<const mpc::SampledReference> reference,
                     std::shared_ptr<const world::Terrain> terrain)
    : BaselineAgent(options, std::move(reference), std::move(terrain)), policy_(std::move(policy)) {
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
  in.terrain_clearance_m = o.terrain_clearance_m;
  in.min_altitude_m = o.min_altitude_m;
  in.max_altitude_m = o.max_altitude_m;
  for (const world::Threat& th : threats())
    in.obstacles.push_back({th.centre_at(t_s), th.velocity_m_s, th.radius_m});
  for (const Neighbour& n : neighbours()) {
    const auto& pts = n.prediction.positions_m;
    const Vec3 velocity = pts.size() >= 2
                              ? Vec3((pts.back() - pts.front()) /
                                     (n.prediction.step_s * static_cast<double>(pts.size() - 1)))
                              : Vec3::Zero();
    in.obstacles.push_back({n.at(t_s), velocity, o.separation_m});
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
    next_decision_s_ = t_s + policy_->action_period_s();
  }
  rollout(state, last_command(), held_, wind_m_s, o.prediction_step_s, o.prediction_steps,
          prediction);
  return held_;
}

}  // namespace ridgeline::baselines
