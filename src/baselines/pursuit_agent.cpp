#include "baselines/pursuit_agent.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace ridgeline::baselines {

PursuitAgent::PursuitAgent(const BaselineAgentOptions& options, const world::SafetyLimits& limits,
                           const PursuitOptions& pursuit,
                           std::shared_ptr<const mpc::SampledReference> reference,
                           std::shared_ptr<const world::Terrain> terrain)
    : BaselineAgent(options, limits, std::move(reference), std::move(terrain)), pursuit_(pursuit) {
  if (!(pursuit.min_lookahead_m > 0.0 && pursuit.lookahead_time_s > 0.0))
    throw InputError("pursuit.min_lookahead_m", "lookahead distance and time must be positive");
}

vehicle::Input PursuitAgent::compute(double t_s, const vehicle::State& state, const Vec3& wind_m_s,
                                     std::vector<Vec3>& prediction) {
  const BaselineAgentOptions& o = options();
  const vehicle::VehicleParams& vp = o.vehicle;
  const Vec3 p = state.head<3>();
  const double v = std::max(state[vehicle::kV], vp.min_speed_m_s());
  const double dt = last_t_s_ < 0.0 ? 0.0 : t_s - last_t_s_;
  last_t_s_ = t_s;

  // Carrot, pushed out of sensed threats.
  const double lookahead = std::max(pursuit_.min_lookahead_m, pursuit_.lookahead_time_s * v);
  Vec3 carrot = path().at(progress_m() + lookahead);
  for (const world::Threat& th : threats()) {
    const Vec3 c = th.centre_at(t_s);
    const double keep = th.radius_m + limits().threat_margin_m + pursuit_.threat_clearance_m;
    const Vec2 a = p.head<2>(), b = carrot.head<2>(), cc = c.head<2>();
    const Vec2 ab = b - a;
    const double f =
        ab.squaredNorm() > 0 ? std::clamp((cc - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
    const Vec2 closest = a + f * ab;
    if ((closest - cc).norm() >= keep) continue;
    // Sideways, on the UAV's side of the line centre → carrot.
    Vec2 side(-ab.y(), ab.x());
    if (side.norm() < 1e-9) side = Vec2(1.0, 0.0);
    side.normalize();
    if (side.dot(a - cc) < 0.0) side = -side;
    const Vec2 pushed = cc + side * keep + (b - closest);
    carrot.head<2>() = pushed;
    ++mutable_counters().replans;
  }

  // Heading: ground direction to the carrot, crab angle for the wind.
  Vec2 d = carrot.head<2>() - p.head<2>();
  const double dist = std::max(d.norm(), 1e-6);
  d /= dist;
  const Vec2 w = wind_m_s.head<2>();
  const double cross = w.x() * d.y() - w.y() * d.x();
  const Vec2 n(-d.y(), d.x());
  const double along = std::sqrt(std::max(0.0, v * v - cross * cross));
  const Vec2 air = along * d - cross * n;
  const double heading = std::atan2(air.y(), air.x());
  const double alpha = wrap_angle(heading - state[vehicle::kPsi]);
  const double turn = 2.0 * v * std::sin(alpha) / std::max(dist, 1.0);

  // Speed PID on the along-track error to the timed reference.
  const mpc::ReferencePoint ref = reference().at(std::min(t_s, reference().end_time_s()));
  const double s_ref = path().project(ref.position_m, std::max(0.0, progress_m() - 200.0), 400.0);
  const double e = s_ref - progress_m();
  speed_integral_ = std::clamp(speed_integral_ + e * dt, -200.0, 200.0);
  const double speed =
      ref.speed_m_s + pursuit_.speed_kp_1_s * e + pursuit_.speed_ki_1_s2 * speed_integral_;

  // Altitude PID on the path's height at the projection, with a terrain guard.
  const double s_ahead = progress_m() + v * 1.0;
  const double z_path = path().at(progress_m()).z();
  const double climb_ff = (path().at(s_ahead).z() - z_path) / 1.0;
  double climb = climb_ff + pursuit_.altitude_kp_1_s * (z_path - p.z()) +
                 pursuit_.altitude_kd * (climb_ff - state[vehicle::kW]);
  const Vec3 ahead =
      p + pursuit_.lookahead_time_s * v *
              Vec3(std::cos(state[vehicle::kPsi]), std::sin(state[vehicle::kPsi]), 0.0);
  if (std::min(clearance_m(p), clearance_m(ahead)) <
      limits().terrain_clearance_m + pursuit_.terrain_guard_m)
    climb = vp.max_climb_rate_m_s;
  if (p.z() > limits().altitude.max_m - 10.0) climb = std::min(climb, 0.0);

  // Saturation: w_max, and 90 % of the pitch limit at the current speed (the climb lag).
  const double climb_max = std::min(
      vp.max_climb_rate_m_s, 0.9 * std::max(state[vehicle::kV], 0.0) * std::tan(vp.max_pitch_rad));
  const vehicle::Input u(speed, turn, std::clamp(climb, -climb_max, climb_max));
  // Broadcast: the current command held.
  std::vector<Vec3> rolled;
  rollout(state, last_command(), u, wind_m_s, o.prediction_step_s, o.prediction_steps, rolled);
  prediction = std::move(rolled);
  return u;
}

}  // namespace ridgeline::baselines
