// Separation-aware initial guesses for the joint optimizer (DESIGN §5, eq. 21): prioritized
// altitude layering of the UAVs' timed guesses on the shared grid, so that Ipopt starts from
// paths that are already apart at equal times instead of pulling crossing or stacked UAVs apart
// itself (with ten UAVs that took it ~1600 iterations).
//
// Input: per UAV its guess p_{i,k}, k = 0 … n_i, on the grid t_k = k·Δt (a UAV holds at its last
// point after n_i), which waypoints are fixed (start, targets), and its climb budget per step
// c_i = w_max·Δt. Output: the same guesses with z raised by a lift Δ_{i,k} ≥ 0 so that, as far as
// the limits below allow, every pair keeps ≥ D (separation_m) at every grid time and at every
// time between (positions are linear in time on a step, so the step's minimum is exact).
//
// Priorities. UAVs are processed by increasing route duration n_i (ties: by index), and a UAV is
// only moved against those processed before it. So the UAV being moved is never the one holding
// at its final point while the other still flies: holding points are fixed and cannot be lifted.
//
// The lift of UAV i. Against an earlier UAV j at time t, with horizontal distance h < D and
// vertical offset δz = z_i − z_j, a uniform lift Δ is forbidden on (−δz − v, −δz + v),
// v = √(D² − h²). Per index k, need_k is the least Δ ≥ lower_k outside every forbidden interval
// of k's point and of the steps k−1→k and k→k+1 (evaluated at the step's horizontally closest
// time); the lift is then the least majorant of need with |Δ_{k+1} − Δ_k| ≤ s_k, where
// s_k = max(0, c_i − |z_{k+1} − z_k|) is what the guess leaves of the climb budget on step k
// (so the lifted guess keeps |d_z| ≤ w_max·Δt), capped by U_k: zero at fixed waypoints,
// growing at the slopes s away from them, and H_max − z_k. The exact separations of the lifted
// guess are checked; a step still in conflict raises lower on both its ends above the larger of
// their lifts, and the passes repeat until none is left or nothing changes. Lifting only raises
// z over the same horizontal track, so terrain clearance (eq. 19–20), the speed band and the
// climb limit of the guess are kept; H_max is kept by the cap.
//
// Time offsets. Where the caps leave conflicts — typically two UAVs whose routes cross right after
// take-off while both climb at w_max, so there is no climb budget left for a lift — the UAV is
// delayed instead: from the fixed point (start or target) that begins the leg of its first
// conflict it flies at slow_speed_ratio × its guess's speed (never below its v0 − Δv) until it is
// m steps late, then at its guess's speed again; the later points, fixed ones included, move m
// grid indices later (its route, the horizontal track and every point's clearance unchanged, the
// climb per step only smaller). m = 1 … max_delay_steps is tried, each lifted again, and the one
// leaving the fewest conflicts kept; up to three legs are delayed in turn. Conflicts neither can
// remove stay for Ipopt and are counted.
#pragma once

#include <limits>
#include <vector>

#include "core/types.hpp"
#include "world/safety_limits.hpp"

namespace ridgeline::planning {

struct GuessDeconflictionOptions {
  double separation_m = 20.0;     ///< D > 0: wanted separation of the guesses at equal times
  double slope_fraction = 0.9;    ///< (0, 1]: share of the remaining climb budget a lift uses
  int max_passes = 30;            ///< ≥ 1 per UAV
  int max_delay_steps = 4;        ///< ≥ 0: longest delay tried on a leg, in grid steps
  double slow_speed_ratio = 0.7;  ///< (0, 1): speed of a delayed UAV's slow part / its guess's
};

/// One UAV's grid guess (modified in place by deconflict_guesses).
struct GuessUav {
  std::vector<Vec3> guess_m;      ///< n + 1 points at t_k = k·Δt (≥ 2)
  std::vector<char> fixed;        ///< per point: 1 if it must not move
  double max_climb_step_m = 0.0;  ///< c = w_max·Δt (> 0)
  double min_speed_ratio = 0.5;   ///< [0, 1): (v0 − Δv)/v0, the slowest a delay may fly
  /// > 0: tan θ_max; a lift's climb on a step stays within this × the step's horizontal length
  double max_grade = std::numeric_limits<double>::infinity();
};

struct GuessDeconflictionSummary {
  double min_separation_before_m = std::numeric_limits<double>::infinity();  ///< ∞: one UAV
  double min_separation_after_m = std::numeric_limits<double>::infinity();
  int conflicts_before = 0;  ///< (pair, step) with a separation below D, before
  int conflicts_after = 0;   ///< the same after (those the caps left)
  int lifted_uavs = 0;       ///< UAVs with a lift > 0
  int delayed_uavs = 0;      ///< UAVs with a time offset
  int delay_steps = 0;       ///< sum of the delays, in grid steps
  double max_lift_m = 0.0;
};

/// Exact minimum distance between two UAVs on step k → k+1 (positions linear in time on the
/// step, each holding at its last point after its end).
double step_min_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b, int k);

/// Minimum over all pairs and steps of step_min_distance, and the number of (pair, step) below
/// separation_m.
double min_guess_separation(const std::vector<GuessUav>& uavs, double separation_m,
                            int* conflicts = nullptr);

/// Lifts and delays the guesses (file comment); a delayed guess has more points (and its fixed
/// flags move with them). Throws InputError on bad options or inconsistent sizes.
/// No lift goes above `band.max_m` (H_max).
GuessDeconflictionSummary deconflict_guesses(std::vector<GuessUav>& uavs,
                                             const world::AltitudeBand& band,
                                             const GuessDeconflictionOptions& options = {});

}  // namespace ridgeline::planning
