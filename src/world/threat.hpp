// Sudden moving threats (DESIGN §4, paper eq. 13): spheres |p − c(t)| ≤ R with
// c(t) = c0 + v_T·(t − t_appear), existing only for t_appear ≤ t ≤ t_vanish.
//
// Positions are ENU metres, times seconds on the mission clock. The global planner never
// sees a threat; a UAV senses it (sensed_by) and broadcasts it (DESIGN §1).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "core/types.hpp"

namespace ridgeline::world {

struct Threat {
  std::string name;
  Vec3 centre_m = Vec3::Zero();      ///< c0: centre at t_appear
  Vec3 velocity_m_s = Vec3::Zero();  ///< v_T, constant
  double radius_m = 0.0;             ///< R, > 0
  double appear_s = 0.0;             ///< t_appear
  double vanish_s = 1e9;             ///< t_vanish, > t_appear

  /// True while the threat exists: t_appear ≤ t ≤ t_vanish (both ends included).
  bool active(double t_s) const { return appear_s <= t_s && t_s <= vanish_s; }

  /// c(t) = c0 + v_T·(t − t_appear) of eq. 13. Defined (extrapolated) for every t so that
  /// predictions may be made before or after the activity window; check active() for
  /// existence.
  Vec3 centre_at(double t_s) const { return centre_m + velocity_m_s * (t_s - appear_s); }

  /// Signed distance from p to the sphere's surface at time t: |p − c(t)| − R (m), negative
  /// inside the sphere, +infinity while the threat is inactive (it is then nowhere).
  double surface_distance(const Vec3& p_m, double t_s) const;

  /// Whether a sensor at `sensor_p_m` with range `sensor_range_m` (≥ 0) senses the threat at
  /// time t: the threat is active and its nearest surface point is within range,
  /// surface_distance ≤ sensor_range_m. The surface rather than the centre counts because a
  /// radar or camera detects the body's nearest point, so a larger threat is seen earlier;
  /// a sensor inside the sphere (negative distance) senses it too.
  bool sensed_by(const Vec3& sensor_p_m, double sensor_range_m, double t_s) const;
};

/// Throws ridgeline::InputError naming `<field_prefix>.<field>` (e.g. `threats[2].radius_m`)
/// unless centre_m, velocity_m_s, appear_s and vanish_s are finite, radius_m is finite and
/// > 0, and vanish_s > appear_s.
void validate(const Threat& threat, std::string_view field_prefix);

/// Closest approach between a threat and a point moving uniformly, p(t) = p_ref + v·(t − t_ref).
struct ClosestApproach {
  double time_s = 0.0;                  ///< t* at which the centre distance is smallest
  double centre_distance_m = 0.0;       ///< |p(t*) − c(t*)|
  double surface_distance_m = 0.0;      ///< centre_distance_m − R, negative means intrusion
  Vec3 point_m = Vec3::Zero();          ///< p(t*)
  Vec3 threat_centre_m = Vec3::Zero();  ///< c(t*)
};

/// Time of closest approach of `threat` to the uniformly moving point over the window
/// [max(t_begin, t_appear), min(t_end, t_vanish)]. The relative position
/// d(t) = d_ref + (v − v_T)(t − t_ref) gives |d|² quadratic in t with its minimum at
/// t* = t_ref − d_ref·Δv / |Δv|², clamped to the window (the window's start if Δv = 0).
/// Empty (std::nullopt) when the window is empty: the threat never exists during it.
std::optional<ClosestApproach> closest_approach(const Threat& threat, const Vec3& point_ref_m,
                                                const Vec3& point_velocity_m_s, double t_ref_s,
                                                double t_begin_s, double t_end_s);

}  // namespace ridgeline::world
