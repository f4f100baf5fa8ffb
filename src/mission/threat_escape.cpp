#include "mission/threat_escape.hpp"

#include <algorithm>
#include <cmath>

namespace ridgeline::mission {

ThreatEscape assess_escape(const vehicle::State& state, const Vec3& wind_m_s,
                           const vehicle::VehicleParams& params, const world::Threat& threat,
                           double t_s) {
  constexpr double kStep_s = 0.01;
  constexpr double kHorizon_s = 120.0;  // beyond this a UAV has every chance to leave
  const Vec3 p0 = state.head<3>();
  const double v0 = state[vehicle::kV];
  const double psi = state[vehicle::kPsi];
  const double omega0 = std::abs(state[vehicle::kOmega]);
  const double w0 = state[vehicle::kW];
  const Vec3 ground_velocity = Vec3(v0 * std::cos(psi), v0 * std::sin(psi), w0) + wind_m_s;
  const Vec3 relative_p0 = p0 - threat.centre_at(t_s);
  const Vec3 relative_v = ground_velocity - threat.velocity_m_s;
  const double v_max = params.max_speed_m_s();
  const double omega_max = v_max / params.min_turn_radius_m;
  // The first-order lags (eq. 1) bound how far each rate can have moved after s seconds:
  //   |v(s) − v0| ≤ Δv·(1 − e^{−s/τ_v}), Δv the farther end of the speed band from v0,
  //   |ω(s)| ≤ |ω0|·e^{−s/τ_ω} + ω_max·(1 − e^{−s/τ_ω}), so the heading moved by at most Ψ(s) =
  //   ∫|ω|, |w(s) − w0| ≤ (w_max + |w0|)·(1 − e^{−s/τ_w}).
  // The horizontal velocity then differs from the initial one by at most
  // |v − v0| + v_max·min(Ψ, 2) (|ê(ψ) − ê(ψ0)| ≤ min(|ψ − ψ0|, 2)), and its integral bounds D_h.
  const double speed_reach = std::max(v_max - v0, v0 - params.min_speed_m_s());
  const double climb_reach = params.max_climb_rate_m_s + std::abs(w0);

  ThreatEscape out;
  double heading_bound = 0.0, horizontal_reach = 0.0, vertical_reach = 0.0;
  const double end_s = std::min(kHorizon_s, threat.vanish_s - t_s);
  for (double tau = 0.0; tau <= end_s; tau += kStep_s) {
    if (threat.active(t_s + tau)) {
      const double straight = (relative_p0 + relative_v * tau).norm();
      if (straight <= threat.radius_m && !std::isfinite(out.time_to_contact_s))
        out.time_to_contact_s = tau;
      if (straight + std::hypot(horizontal_reach, vertical_reach) < threat.radius_m)
        out.unavoidable = true;
      if (out.unavoidable && std::isfinite(out.time_to_contact_s)) break;
    }
    // Advance the bounds over [τ, τ + step] with the rates' bounds at the step's end (they grow
    // with s, so this over-approximates: a larger reach only makes "unavoidable" rarer).
    const double s1 = tau + kStep_s;
    const double omega_bound = omega0 * std::exp(-s1 / params.tau_omega_s) +
                               omega_max * (1.0 - std::exp(-s1 / params.tau_omega_s));
    heading_bound += std::max(omega0, omega_bound) * kStep_s;
    const double velocity_reach =
        speed_reach * (1.0 - std::exp(-s1 / params.tau_v_s)) + v_max * std::min(heading_bound, 2.0);
    horizontal_reach += velocity_reach * kStep_s;
    vertical_reach += climb_reach * (1.0 - std::exp(-s1 / params.tau_w_s)) * kStep_s;
  }
  return out;
}

}  // namespace ridgeline::mission
