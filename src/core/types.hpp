// Small shared numeric types. World frame is ENU (x east, y north, z up), SI units.
#pragma once

#include <Eigen/Core>

namespace ridgeline {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using VecX = Eigen::VectorXd;
using MatX = Eigen::MatrixXd;

constexpr double kPi = 3.14159265358979323846;
constexpr double kGravity_m_s2 = 9.80665;

constexpr double deg_to_rad(double deg) { return deg * kPi / 180.0; }
constexpr double rad_to_deg(double rad) { return rad * 180.0 / kPi; }

/// floor(f) clamped to [0, last] (last ≥ 0), the segment of a sampled sequence that a
/// fractional sample index f falls in; a NaN f gives 0. By truncating f clamped first: on
/// the baseline x86-64 std::floor is a library call, and the look-ups of predictions and
/// references take it thousands of times a simulated second.
inline int segment_index(double f, int last) {
  return static_cast<int>(f > 0.0 ? (f < last ? f : static_cast<double>(last)) : 0.0);
}

/// An angle outside (-pi, pi] wrapped into it (wrap_angle's library call).
double wrap_angle_outside(double angle_rad);

/// Wraps an angle to (-pi, pi]. Inline: the common case, a heading difference already in the
/// range, is two comparisons, and the MPC takes dozens of them a step.
inline double wrap_angle(double angle_rad) {
  if (angle_rad > -kPi && angle_rad <= kPi) return angle_rad;
  return wrap_angle_outside(angle_rad);
}

}  // namespace ridgeline
