// Reference trajectories r(t) for the UAV tracker (DESIGN §3, §5: the global planner's
// time-parametrized output r_i(t)).
//
// A reference gives, at mission time t (s), the position (ENU, m), the heading of horizontal
// motion ψ_r (rad from east, counter-clockwise), the horizontal speed (m/s), the turn rate
// ψ̇_r (rad/s) and the vertical speed ż_r (m/s): everything the tracker needs to linearize the
// vehicle model (eq. 1) along it. Headings may be given unwrapped or wrapped; consumers unwrap
// them relative to their own state.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "core/types.hpp"
#include "messages/messages.hpp"

namespace ridgeline::mpc {

/// A sample of r(t); defined with the messages, since the ground station sends it (ReferencePlan).
using ReferencePoint = messages::ReferencePoint;

/// Interface: r(t). Implementations are immutable and thread-safe.
class ReferenceTrajectory {
 public:
  virtual ~ReferenceTrajectory() = default;
  virtual ReferencePoint at(double t_s) const = 0;
  /// out[j] = at(t0_s + j·step_s) for every j, step_s ≥ 0: the tracker's Np + 1 samples of a
  /// step. An implementation may take them together (a sampled reference walks its samples
  /// forward instead of searching for each, a helix takes its sines and cosines four at a
  /// time); each says whether its samples equal at()'s bit for bit. This one asks at().
  virtual void sample(double t0_s, double step_s, std::span<ReferencePoint> out) const;
};

/// Piecewise-linear interpolation of samples (t_i, r_i); headings are interpolated along the
/// shorter arc. Outside [t_0, t_N] the trajectory is extrapolated at the end sample's velocity
/// (position moves on with heading, speed and climb rate held), so a tracker whose horizon
/// overhangs the end of a plan keeps a consistent reference.
class SampledReference : public ReferenceTrajectory {
 public:
  /// Throws ridgeline::InputError (field `times_s` / `points`) unless the sizes match, there
  /// are ≥ 2 samples, the times are finite and strictly increasing and all values are finite.
  SampledReference(std::vector<double> times_s, std::vector<ReferencePoint> points);

  /// Builds the samples from positions alone: heading, speed, turn and climb rates by central
  /// differences (one-sided at the ends). Same checks as the constructor; additionally no two
  /// consecutive positions may coincide horizontally (the heading would be undefined).
  static SampledReference from_positions(const std::vector<double>& times_s,
                                         const std::vector<Vec3>& positions_m);

  ReferencePoint at(double t_s) const override;
  /// Equal to at() bit for bit.
  void sample(double t0_s, double step_s, std::span<ReferencePoint> out) const override;
  /// out[j] = at(times_s[j]) bit for bit, for times that increase (as a delayed plan's times
  /// do): each look-up walks on from the one before. Times out of order are searched for.
  void at_increasing(std::span<const double> times_s, std::span<ReferencePoint> out) const;
  double start_time_s() const { return times_s_.front(); }
  double end_time_s() const { return times_s_.back(); }

 private:
  /// The sample i with times[i] ≤ t < times[i + 1], for front < t < back.
  std::size_t segment(double t_s) const;
  /// r(t) between samples i and i + 1.
  ReferencePoint interpolate(std::size_t i, double t_s) const;

  std::vector<double> times_s_;
  std::vector<ReferencePoint> points_;
};

/// Uniform helix (a circle when the climb rate is zero), flown counter-clockwise seen from
/// above when turn_left, clockwise otherwise:
///   φ(t) = φ0 ± (v/R)(t − t0),  p = c + R[cos φ, sin φ, 0] + [0, 0, ż (t − t0)],
///   ψ = φ ± π/2,  ψ̇ = ±v/R.
class HelixReference : public ReferenceTrajectory {
 public:
  struct Config {
    Vec3 centre_m = Vec3::Zero();  ///< centre at t0 (z: height at t0)
    double radius_m = 150.0;       ///< > 0
    double speed_m_s = 10.0;       ///< horizontal speed, > 0
    double climb_rate_m_s = 0.0;
    double phase0_rad = 0.0;  ///< φ0: position angle at t0
    bool turn_left = true;
    double t0_s = 0.0;
  };
  /// Throws ridgeline::InputError for a non-positive radius or speed, or non-finite values.
  explicit HelixReference(const Config& config);
  ReferencePoint at(double t_s) const override;
  /// Equal to at() to round-off: the sines and cosines are core/sin_cos.hpp's (a few ulp).
  void sample(double t0_s, double step_s, std::span<ReferencePoint> out) const override;

 private:
  /// The point at t0 + dt, position angle φ (cos φ, sin φ given).
  ReferencePoint point(double dt_s, double phi_rad, double cos_phi, double sin_phi) const;
  double omega_rad_s() const;

  Config c_;
};

}  // namespace ridgeline::mpc
