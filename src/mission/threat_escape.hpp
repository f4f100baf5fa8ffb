// Was an intrusion avoidable? At the moment a UAV first senses a threat, compare where the
// threat will be with where the UAV can possibly be, given its limits (issue 19, part 4).
//
// From the truth at first sensing (position p0, ground velocity v0, the threat's centre c0 and
// velocity v_T, radius R), the UAV's position at τ ≥ 0 differs from its straight continuation
// p0 + v0·τ by at most D(τ), whatever it commands: the first-order lags of eq. 1 (the truth's
// own time constants) bound how far the speed, the turn rate (|ω_c| ≤ v/R_min) and the climb
// rate (|w_c| ≤ w_max) can have moved after s seconds, hence how far the velocity can differ
// from v0, and D(τ) = √(D_h² + D_z²) integrates those bounds (threat_escape.cpp says how).
// If at some τ while the threat exists |p0 + v0·τ − c0 − v_T·τ| + D(τ) < R, the UAV is inside
// the sphere at τ whatever it does: the intrusion was UNAVOIDABLE when sensed. Otherwise an
// escape existed and an intrusion is the planner's or controller's fault (avoidable). τ is
// checked every 10 ms: a miss of the exact minimum can only call an unavoidable case avoidable,
// never the reverse. Gust changes of the wind are not modelled (the mean moves both paths alike).
#pragma once

#include <limits>

#include "core/types.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/threat.hpp"

namespace ridgeline::mission {

struct ThreatEscape {
  /// When the straight continuation first touches the sphere (s after sensing); +∞ if never
  /// while the threat exists, 0 if already inside.
  double time_to_contact_s = std::numeric_limits<double>::infinity();
  bool unavoidable = false;  ///< no command of the limits keeps the UAV out (see above)
};

/// The escape analysis at time t_s for a UAV in true state `state` (eq. 1) in wind `wind_m_s`
/// with limits `params`, against `threat`.
ThreatEscape assess_escape(const vehicle::State& state, const Vec3& wind_m_s,
                           const vehicle::VehicleParams& params, const world::Threat& threat,
                           double t_s);

}  // namespace ridgeline::mission
