// Time parametrization of a planned path into the tracker's reference r_i(t) (DESIGN §5, last
// step of the global planner: "time-parametrize into a reference r_i(t) respecting speed,
// turn-radius and climb limits").
//
// Input: a 3-D polyline of waypoints p_0 … p_n (ENU, m), e.g. the optimizer's output.
// Output: an mpc::SampledReference sampled every control period Δt.
//
// 1. Cleaning. Consecutive waypoints closer than merge_tolerance_m horizontally are merged
//    (the earlier one is kept, except that the last waypoint is always kept). If their heights
//    differ, the path had a vertical segment (pitch 90°): a kPitch violation is reported.
//
// 2. Geometry. The path is a horizontal curve parametrized by horizontal arc length s, with
//    height z(s) linear on every piece (constant grade g = dz/ds). Each corner of turn angle φ
//    is rounded with a circular arc of radius R tangent to both segments; its tangent points
//    lie L_t = R·tan(φ/2) before and after the vertex. The arc may use at most half of an
//    interior segment (all of the first/last segment). The target radius is R* = k_s·R_min
//    (k_s = turn_radius_safety_factor), or, for CornerRounding::kWidest, the largest radius
//    that fits. If R* does not fit, the arc is shrunk to fit: R = L_avail / tan(φ/2); a radius
//    below R_min is reported as a kTurnRadius violation — never hidden. A corner of
//    φ ≥ loop_turn_angle_rad (a reversal) whose arc does not fit is instead flown as a loop
//    that leaves and re-enters the vertex ("light-bulb" turn: arcs of radius R* turning −α,
//    +(φ+2α), −α, α = 60° for a full reversal); it needs no segment length but leaves the
//    polyline by up to ≈ 2.7·R* beyond the vertex. Heights: between the path points of two
//    consecutive waypoints (a vertex, its arc's midpoint, its loop's far point) z is linear in
//    the flown horizontal arc length (loops are flown level), so each waypoint's height is met
//    at its path point, and a corner steepens the two stretches beside it only by the length
//    its arc cuts, R·(tan(φ/2) − φ/2), shared over each whole stretch.
//    Vertical corners are not blended: where the grade changes, the climb rate ż steps (the
//    tracker's climb lag τ_w absorbs the step; horizontal velocity is continuous everywhere).
//
// 3. Speed profile v(s) (horizontal speed). Each piece has a speed cap
//      v̄ = min(v_cruise, v0 + Δv, w_max/|g|, √(a_lat·R))   floored at v0 − Δv,
//    so that the climb rate w = v·g satisfies |w| ≤ w_max (eq. 2) and the turn rate ω = v·κ
//    satisfies |ω| ≤ v/R_min (eq. 3) exactly when κ = 1/R ≤ 1/R_min, at any speed. If even
//    v0 − Δv gives |w| > w_max, a kClimbRate violation names the segment. The pitch
//    θ = atan(|g|) (= atan2(|w|, v)) does not depend on speed: |θ| > θ_max is a kPitch
//    violation. The profile is the largest v(s) ≤ v̄(s) with |d(v²)/ds| ≤ 2·a_max (the usual
//    forward–backward pass), starting at the initial speed (default: the cruise speed).
//    a_max defaults to 1 m/s²: the speed loop (lag τ_v = 0.5 s) follows such a ramp with a lag
//    of a_max·τ_v = 0.5 m/s, a tenth of the default band. On every piece the profile consists of
//    phases of constant acceleration α ∈ {+a_max, 0, −a_max} (v² linear in s), so s(t) is
//    known in closed form: s = s_0 + v_0 τ + ½ α τ². There is no approximation in the timing.
//
// 4. Sampling at t_k = t_start + kΔt (and at the end time T): position, heading ψ (tangent
//    direction, unwrapped along the path), speed v, turn rate ψ̇ = σ·v/R on arcs (σ = +1 left,
//    −1 right), 0 on lines, climb rate ż = v·g. Positions are exact points of the path, so
//    integrating (v cos ψ, v sin ψ, ż) reproduces them up to the quadrature error.
//
// Timed mode (time_parametrize_timed): waypoint k should be passed at its planned time t_k of
// the optimizer's shared time grid (so separations planned at equal times, eq. 21, remain
// valid). Each waypoint is matched to a point of the path (the vertex on a line, the midpoint
// of its corner arc, the far point of its loop). The target time function T*(s) interpolates
// (s_k, t_k) linearly. Per leg k → k+1 the cap v̄ is further limited by a leg speed
//   u_k = clamp(W_k / (T*(b_k) − T*(a_k)), v0 − Δv, v0 + Δv),
// the box filter of the slowness dT*/ds over a window [a_k, b_k] of timing_window_m around the
// leg (it preserves ∫ slowness ds = time, and adjacent legs then differ little, so the a_max
// ramps cost little time). The profile's arrival errors e_k = t(p_k) − t_k then correct the
// target, t*_k ← t*_k − e_k (iterative learning, max_timing_iterations times, best kept). The
// deviation that remains (legs that need a speed outside the band, or speed changes faster than
// a_max allows, or slower than the geometry allows) is reported.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/types.hpp"
#include "mpc/reference.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::planning {

enum class CornerRounding {
  kTightest,  ///< radius k_s·R_min: the path stays closest to the (validated) waypoints
  kWidest,    ///< the largest radius that fits: lowest turn rates, larger deviation
};

struct TimeParametrizationOptions {
  double control_period_s = 0.02;          ///< Δt: MPC control period (50 Hz)
  std::optional<double> cruise_speed_m_s;  ///< speed to aim for; default v0. Clamped to band
  double start_time_s = 0.0;               ///< t of the first sample (timed mode: t_0)
  CornerRounding corner_rounding = CornerRounding::kTightest;
  double turn_radius_safety_factor = 1.2;  ///< k_s ≥ 1: target radius k_s·R_min (margin for
                                           ///< the turn-rate lag τ_ω while tracking)
  double max_accel_m_s2 = 1.0;             ///< a_max > 0 on dv/dt (file comment, step 3)
  double max_lateral_accel_m_s2 = std::numeric_limits<double>::infinity();  ///< a_lat: v²/R
  std::optional<double> initial_speed_m_s;  ///< default: cruise (or u_0 in timed mode)
  std::optional<double> final_speed_m_s;    ///< default: free
  double merge_tolerance_m = 1e-3;          ///< ≥ 1e-6: horizontal distance to merge points
  double loop_turn_angle_rad = deg_to_rad(150.0);  ///< φ from which a non-fitting corner loops
  // Timed mode only.
  int max_timing_iterations = 50;  ///< corrections of the target time function
  double timing_window_m = 60.0;   ///< W ≥ 0: slowness smoothing window (arc length)
  double time_tolerance_s = 0.5;   ///< |t(p_k) − t_k| above this → kTimingMissed
};

enum class TimeParametrizationStatus {
  kOk,             ///< every sample respects every limit (and timing, in timed mode)
  kLimitViolated,  ///< reference produced, but `violations` lists limits it breaks
  kTimingMissed,   ///< timed mode: limits respected, some waypoint off by > time_tolerance_s
  kInvalidInput,   ///< no reference; `message` is "field: reason"
};
std::string_view to_string(TimeParametrizationStatus status);

enum class LimitKind {
  kTurnRadius,    ///< corner radius R < R_min: |ω| = v/R > v/R_min
  kClimbRate,     ///< v0 − Δv already gives |w| = v·|g| > w_max
  kPitch,         ///< atan(|g|) > θ_max (any speed)
  kLateralAccel,  ///< v0 − Δv already gives v²/R > a_lat
};
std::string_view to_string(LimitKind kind);

/// One broken limit on a stretch of the reference.
struct LimitViolation {
  LimitKind kind = LimitKind::kPitch;
  int waypoint = 0;        ///< input index: the corner's vertex, or a segment's first point
  double value = 0.0;      ///< radius (m), climb rate (m/s), pitch (rad) or lateral accel (m/s²)
  double limit = 0.0;      ///< R_min, w_max, θ_max or a_lat
  double t_begin_s = 0.0;  ///< stretch of the reference where it applies
  double t_end_s = 0.0;
  std::string description;
};

struct TimeParametrizationResult {
  TimeParametrizationStatus status = TimeParametrizationStatus::kInvalidInput;
  std::string message;

  std::optional<mpc::SampledReference> reference;  ///< empty only for kInvalidInput
  std::vector<double> sample_times_s;              ///< the samples of `reference`
  std::vector<mpc::ReferencePoint> samples;

  double duration_s = 0.0;           ///< T − t_start
  double path_length_m = 0.0;        ///< 3-D length of the flown (rounded) path
  double horizontal_length_m = 0.0;  ///< its horizontal arc length
  double max_turn_rate_rad_s = 0.0;  ///< max |ψ̇| over samples
  double max_curvature_1_m = 0.0;    ///< max κ over the path
  double min_turn_radius_m = std::numeric_limits<double>::infinity();  ///< min R used
  double max_climb_rate_m_s = 0.0;                                     ///< max |ż| over samples
  double max_pitch_rad = 0.0;  ///< max atan(|g|) over the path
  double min_speed_m_s = 0.0;  ///< over samples
  double max_speed_m_s = 0.0;
  int corners_rounded = 0;             ///< corners flown on an arc
  int corners_tightened = 0;           ///< of those, arcs shrunk below k_s·R_min to fit
  int corners_slowed = 0;              ///< corners whose arc speed cap is below the cruise speed
  int reversal_loops = 0;              ///< corners flown as a loop through the vertex
  int duplicates_removed = 0;          ///< waypoints merged in cleaning
  double max_waypoint_offset_m = 0.0;  ///< max distance from a waypoint to its path point
  std::vector<LimitViolation> violations;

  /// Time at which the reference passes (the path point of) each input waypoint.
  std::vector<double> waypoint_times_s;
  double max_time_deviation_s = 0.0;  ///< timed mode: max |waypoint_times_s[k] − t_k|
  int timing_iterations = 0;
  double compute_time_ms = 0.0;
};

/// Constant-cruise mode: flies the polyline at the cruise speed, slowing only where a limit
/// requires it (file comment). Never throws on bad data: kInvalidInput names the field
/// (`waypoints_m[3]`, `vehicle.min_turn_radius_m`, `options.control_period_s`, …).
TimeParametrizationResult time_parametrize(const std::vector<Vec3>& waypoints_m,
                                           const vehicle::VehicleParams& vehicle,
                                           const TimeParametrizationOptions& options = {});

/// Timed mode: as time_parametrize, but the reference passes waypoint k at ≈ times_s[k]
/// (strictly increasing; the reference starts at times_s[0]; options.start_time_s and
/// options.cruise_speed_m_s are not used: the planned times set the speeds).
TimeParametrizationResult time_parametrize_timed(const std::vector<Vec3>& waypoints_m,
                                                 const std::vector<double>& times_s,
                                                 const vehicle::VehicleParams& vehicle,
                                                 const TimeParametrizationOptions& options = {});

}  // namespace ridgeline::planning
