// Baseline [7]'s on-board part: a dynamic-window local planner (issue 6) following the
// improved-A* path (baseline_planner.hpp), with no MPC.
//
// Every dwa_period_s (10 Hz; the command is held in between) the agent samples commands
// u = (v_c, ω_c, w_c) on a lattice over the admissible set (speed band, |ω_c| ≤ v/R_min,
// |w_c| ≤ w_max) — the dynamic window: each candidate is approached from the current command
// at the command-rate limits, so what can be reached in the horizon is what is scored — and
// rolls each out with the controller's model (eq. 1–4, measured wind) over horizon_s. A
// rollout is admissible when it keeps, at every step, the terrain clearance h_safe, the
// altitude band, r_safe + threat_clearance_m from every threat it has sensed (predicted at its
// velocity) and d_safe + neighbour_clearance_m from every neighbour's broadcast prediction at
// equal times. The admissible rollout of least
//   J = |p_end − g| + w_cross·d_cross + w_speed·|v_c − v_des|
//       + w_obstacle·Σ_threats,neighbours max(0, D − d_min)/D
// is chosen: g the path point v_des·horizon_s ahead of the UAV's projection on its path,
// d_cross the mean distance of the rollout to the path, v_des the speed that keeps the UAV on
// its timed reference (v_ref + k·along-track error), D = influence_m. Without an admissible
// rollout the one with the largest worst margin is flown (and counted as a fallback step).
// The chosen rollout is broadcast as the UAV's prediction.
#pragma once

#include "baselines/baseline_agent.hpp"

namespace ridgeline::baselines {

struct DwaOptions {
  double dwa_period_s = 0.1;
  double horizon_s = 6.0;
  double rollout_step_s = 0.25;
  int speed_samples = 3;
  int turn_samples = 9;
  int climb_samples = 3;
  double threat_clearance_m = 5.0;     ///< beyond R + r_safe
  double neighbour_clearance_m = 5.0;  ///< beyond d_safe
  double influence_m = 60.0;           ///< D
  double weight_cross = 0.5;
  double weight_speed = 2.0;
  double weight_obstacle = 40.0;
  double along_track_gain_1_s = 0.2;  ///< k
};

class DwaAgent final : public BaselineAgent {
 public:
  DwaAgent(const BaselineAgentOptions& options, const world::SafetyLimits& limits,
           const DwaOptions& dwa, std::shared_ptr<const mpc::SampledReference> reference,
           std::shared_ptr<const world::Terrain> terrain);

 protected:
  vehicle::Input compute(double t_s, const vehicle::State& state, const Vec3& wind_m_s,
                         std::vector<Vec3>& prediction) override;

 private:
  DwaOptions dwa_;
  double next_dwa_s_ = -1.0;
  vehicle::Input chosen_ = vehicle::Input::Zero();
  std::vector<Vec3> chosen_rollout_;
  double chosen_at_s_ = 0.0;
};

}  // namespace ridgeline::baselines
