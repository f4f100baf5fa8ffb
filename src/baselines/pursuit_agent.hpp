// Baseline [6]'s on-board part: the offline wind-aware path (baseline_planner.hpp) tracked by
// a non-predictive follower (issue 6): pure pursuit for the heading, PID loops for speed and
// altitude.
//
//  - Pure pursuit: the carrot is the path point lookahead = max(min_lookahead_m,
//    lookahead_time_s·v) ahead of the UAV's projection on the path. The ground direction to
//    it is turned into an air heading with the wind-correction (crab) angle from the measured
//    wind, and ω_c = 2·v·sin α / lookahead (α the heading error): the pure-pursuit arc.
//  - Speed: v_c = v_ref(t) + k_p·e + k_i·∫e, e the along-track distance to the timed
//    reference's position (so the UAV keeps its schedule), within the speed band.
//  - Altitude: w_c = ż_path + k_p·(z_path − z) + k_d·(ż_path − w) at the projection, within
//    ±w_max; when the terrain clearance under the UAV or under the point lookahead_time_s ahead
//    falls below h_safe + terrain_guard_m the follower climbs at w_max.
//  - Threats: the offline path knows none. A threat the UAV senses itself moves the carrot:
//    when the line to it passes within R + r_safe + threat_clearance_m of the threat's
//    centre, the carrot is pushed sideways (away from the centre, on the side the UAV already
//    is) to that distance — the follower's only reaction; counted as an avoidance step.
//  - Neighbours: not considered (the method plans and flies each UAV alone); it broadcasts its
//    position extrapolated at the current command so the transport carries the same traffic.
#pragma once

#include "baselines/baseline_agent.hpp"

namespace ridgeline::baselines {

struct PursuitOptions {
  double min_lookahead_m = 25.0;
  double lookahead_time_s = 2.5;
  double speed_kp_1_s = 0.3;
  double speed_ki_1_s2 = 0.02;
  double altitude_kp_1_s = 0.8;
  double altitude_kd = 0.3;
  double terrain_guard_m = 10.0;
  double threat_clearance_m = 15.0;
};

class PursuitAgent final : public BaselineAgent {
 public:
  PursuitAgent(const BaselineAgentOptions& options, const world::SafetyLimits& limits,
               const PursuitOptions& pursuit,
               std::shared_ptr<const mpc::SampledReference> reference,
               std::shared_ptr<const world::Terrain> terrain);

 protected:
  vehicle::Input compute(double t_s, const vehicle::State& state, const Vec3& wind_m_s,
                         std::vector<Vec3>& prediction) override;

 private:
  PursuitOptions pursuit_;
  double speed_integral_ = 0.0;
  double last_t_s_ = -1.0;
};

}  // namespace ridgeline::baselines
