// Dense validation of timed multi-UAV plans against every hard constraint of the global
// planner (DESIGN §5): terrain clearance (eq. 19–20), the altitude band (eq. 14) and the
// separation at equal times (eq. 21).
//
// A plan is one piecewise-linear path per UAV: waypoints p_0 … p_n with strictly increasing
// times t_0 < … < t_n, position p(t) linear in t between waypoints. Before t_0 a UAV is taken to
// wait at p_0 and after t_n to hold at p_n (a UAV that has finished its route stays there for the
// separation check, the conservative reading).
//
// Checks:
//  - terrain: z − H(x, y) ≥ h_safe + e (e = terrain.model_error_m()) at points spaced at most
//    terrain_step_m (≤ 5 m) of horizontal distance along every segment, both ends included;
//  - altitude band H_min ≤ z ≤ H_max, exact: z is linear on a segment, so its extremes are at
//    the waypoints;
//  - separation |p_i(t) − p_j(t)| ≥ d_safe at every t = t_min + m·separation_period_s (the
//    control period, 0.02 s) over the union of the plans' time spans, for every pair. Pairs are
//    pruned per time window (window_s) by the axis-aligned boxes of the two paths inflated by
//    d_safe: a pair whose boxes are disjoint cannot violate in that window.
// A violation is a sample below its limit by more than tolerance_m. To keep reports short, each
// offending terrain segment, waypoint, or contiguous run of violating separation samples of one
// pair is reported once, at its worst sample.
//
// This module is independent of the optimizer: the `plan` command and the tests reuse it.
#pragma once

#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/types.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"

namespace ridgeline::planning {

/// One UAV's plan: p(t) piecewise linear through (times_s[k], waypoints_m[k]).
struct TimedPath {
  std::string name;
  std::vector<Vec3> waypoints_m;  ///< ≥ 1 point
  std::vector<double> times_s;    ///< same size, strictly increasing
};

/// How densely to check; the limits themselves are the mission's (world::SafetyLimits).
struct PlanValidationOptions {
  /// false: pairs are still measured (min_separation_m) but never reported as violations, for
  /// plans whose separation is left to the flight (the comparison methods' offline paths).
  bool enforce_separation = true;
  double terrain_step_m = 2.0;         ///< (0, 5]: horizontal spacing of terrain samples
  double separation_period_s = 0.02;   ///< > 0: spacing of separation samples in time
  double window_s = 5.0;               ///< > 0: time window of the pair pruning
  double tolerance_m = 1e-6;           ///< ≥ 0: violations smaller than this are ignored
};

enum class ViolationKind {
  kTerrainClearance,  ///< eq. 19–20: z − H(x, y) < h_safe + e
  kAltitudeLow,       ///< eq. 14: z < H_min
  kAltitudeHigh,      ///< eq. 14: z > H_max
  kSeparation,        ///< eq. 21: |p_i(t) − p_j(t)| < d_safe
};
std::string_view to_string(ViolationKind kind);

/// One violation, at its worst sample.
struct PlanViolation {
  ViolationKind kind = ViolationKind::kTerrainClearance;
  int uav = 0;             ///< index into the validated paths
  int other_uav = -1;      ///< kSeparation: the other UAV (> uav); else −1
  int segment = 0;         ///< terrain: segment k (p_k → p_{k+1}); altitude: waypoint k;
                           ///< separation: the segment of `uav` at time_s
  double time_s = 0.0;     ///< time of the worst sample
  Vec3 position_m = Vec3::Zero();  ///< position of `uav` there
  double amount_m = 0.0;   ///< by how much the limit is missed (> 0)
  std::string description; ///< one line naming constraint, UAV(s), time, place and amount
};

struct PlanValidationReport {
  std::vector<PlanViolation> violations;
  double min_clearance_m = std::numeric_limits<double>::infinity();  ///< min z − H over samples
  int min_clearance_uav = -1;
  Vec3 min_clearance_position_m = Vec3::Zero();
  double min_altitude_m = std::numeric_limits<double>::infinity();
  double max_altitude_m = -std::numeric_limits<double>::infinity();
  double min_separation_m = std::numeric_limits<double>::infinity();  ///< ∞ for one UAV
  int min_separation_uavs[2] = {-1, -1};
  double min_separation_time_s = 0.0;
  long terrain_samples = 0;
  long separation_samples = 0;  ///< pair samples actually evaluated (after pruning)
  double compute_time_ms = 0.0;

  bool passed() const { return violations.empty(); }
  /// "passed …" or the first `max_lines` violation descriptions, one per line.
  std::string summary(int max_lines = 5) const;
};

/// Validates `paths` against `limits` (see the file comment). Throws InputError (field
/// `paths[i].…`, `options.…` or the limit's scenario field) on malformed input: empty paths,
/// size mismatch, non-finite values, times not strictly increasing, limits or options out of
/// range.
PlanValidationReport validate_plan(const world::Terrain& terrain,
                                   const std::vector<TimedPath>& paths,
                                   const world::SafetyLimits& limits,
                                   const PlanValidationOptions& options = {});

}  // namespace ridgeline::planning
