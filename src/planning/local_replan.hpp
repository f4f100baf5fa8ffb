// Local re-plan of one UAV around a sudden moving threat (DESIGN §1 "sudden threat" layer, §5;
// issue 4 item 6): the UAV's remaining reference is re-optimized over a time window, against the
// threats it knows and the other UAVs' references, warm-started from its current reference, and
// densely validated like the global plan. Small enough to run on board (one UAV, a window of
// tens of grid points): a few tens of milliseconds.
//
// Window and grid. The window is [t_0, t_1], t_0 = start_time_s, t_1 = min(t_0 + window_s,
// reference_end_time_s), divided into n = ceil((t_1 − t_0)/time_step_s) steps of Δt. The grid
// points are the reference r(t) at t_0 − Δt, t_0, t_0 + Δt, …, t_1 and t_1 + Δt (the last one only
// while r still runs then). The points at and outside t_0 and t_1 are fixed: the new path leaves
// r at t_0 and re-joins it at t_1 exactly, and the turn rows at t_0 and t_1 (whose neighbours are
// r's own points) keep the junctions smooth. The rest is the joint optimizer's NLP
// (trajectory_optimizer.hpp: the same costs eq. 15–23, speed band, climb limit, altitude band
// eq. 14, terrain rows eq. 19–20) for this one UAV, plus constant obstacle rows
// (trajectory_nlp.hpp, ObstacleRow):
//  - threat (eq. 13): at grid time t the point keeps R + r_safe + m from the threat's swept
//    sphere, the capsule of centres c(s), s ∈ [t − δ, t + δ] ∩ [t_appear, t_vanish] ∩ [t_0, t_1],
//    δ = threat_time_margin_s. δ = ∞ (the default) is the sphere swept over the whole window: the
//    path stays clear of everywhere the threat will be during it, whatever the UAV's timing
//    errors. A finite δ is the timed reading, for a UAV that keeps its timing within δ.
//  - separation (eq. 21): at grid time t the point keeps d_safe + m from each other UAV's
//    reference position at t (the others do not move for this UAV's re-plan; they are constants).
// Rows are added where the warm start comes within the prefilter distances; interior samples of
// each step (obstacle_samples_per_step) cover the chords, and the dense check catches the rest.
//
// Warm start. The initial point is the current reference on the grid. Where it runs through a
// threat's swept sphere the guess is shifted sideways (horizontally, perpendicular to the
// window's overall direction, to the side needing the smaller shift), the shift spread over
// neighbouring points at most lateral_rate_m_s so the guess turns in and out smoothly; Ipopt
// then optimizes from there. On an Ipopt failure the other side is tried once.
//
// Validation that cannot be skipped. The re-planned waypoints are time-parametrized in timed
// mode (time_parametrization.hpp) from r's speed at t_0, the samples' times are rescaled to end
// exactly at t_1, and every sample (control period) is checked: terrain clearance every ≤ 5 m
// (validate_plan), the altitude band, R + r_safe from every threat's swept sphere, d_safe from
// every other reference at equal times, the speed band and climb limit after the rescaling, and
// the parametrization's own limits (turn radius, pitch). A violation refines the rows there
// (more interior samples, a larger margin) and the problem is re-solved, warm-started; after
// max_refinements rounds the result is kValidationFailed with the constraint, time and place,
// and no reference. A reference that breaks a hard constraint is never returned.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/types.hpp"
#include "mpc/reference.hpp"
#include "planning/plan_validation.hpp"
#include "planning/time_parametrization.hpp"
#include "planning/trajectory_optimizer.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"

namespace ridgeline::planning {

struct LocalReplanProblem {
  const world::Terrain* terrain = nullptr;              ///< must outlive the call
  const mpc::ReferenceTrajectory* reference = nullptr;  ///< the UAV's current r(t)
  double reference_end_time_s = 0.0;  ///< where r ends (its final target): t_1 ≤ this
  double start_time_s = 0.0;          ///< t_0: the re-planned reference leaves r here
  vehicle::VehicleParams vehicle;
  std::vector<world::Threat> threats;  ///< known threats, predicted by eq. 13
  /// The other UAVs' references (piecewise linear in time, holding before and after their
  /// span, as in plan_validation.hpp). May be empty.
  std::vector<TimedPath> others;
  world::SafetyLimits limits;  ///< r_safe, h_safe, d_safe and the band (the mission's)
};

struct LocalReplanOptions {
  double window_s = 30.0;         ///< > 0: the re-planned stretch of r
  double time_step_s = 1.0;       ///< > 0: grid Δt (the window is divided evenly, ≤ this)
  /// δ ≥ 0 (file comment): the sphere is avoided over [t − δ, t + δ]; ∞ = swept over the window.
  double threat_time_margin_s = std::numeric_limits<double>::infinity();
  double obstacle_margin_m = 1.0;         ///< m ≥ 0 added to the threat and separation rows
  int obstacle_samples_per_step = 1;      ///< ≥ 0 interior threat/separation rows per step
  double threat_prefilter_m = 200.0;      ///< ≥ 0: rows where the guess is within R + this
  double separation_prefilter_m = 100.0;  ///< ≥ 0: rows where the guess is within this
  double lateral_rate_m_s = 5.0;  ///< > 0: warm start's sideways shift grows at most this fast
  /// ≥ 0, below Δv: the grid's speed band is narrowed by this at both ends, so the timing's
  /// rescaling to end exactly at t_1 (a few percent) stays inside the vehicle's band.
  double speed_headroom_m_s = 0.5;
  double climb_headroom_m_s = 0.15;  ///< ≥ 0, below w_max: the same for the climb limit
  /// Weights, penalties, current model, Ipopt tolerances and iteration limit, Hessian mode.
  /// Its grid is the window's; its max_refinements and time_budget_s are replaced by the ones
  /// below. The limits are the problem's.
  TrajectoryOptimizerOptions optimizer = default_optimizer();
  int max_refinements = 3;                 ///< ≥ 0: re-solves after a failed validation
  /// > 0: CPU time of the calling thread over the whole re-plan (screen, solves, checks), as
  /// the global planner's budget (core/cpu_clock.hpp): a lock-step flight gives the same
  /// re-plans on a loaded machine (on board it bounds the wall time while the thread has its core).
  /// The target is a re-plan within 100 ms; past the budget the re-plan fails (kTimeLimit) and
  /// the agent keeps its validated fallback, so the budget bounds the worst case.
  double time_budget_s = 0.09;
  TimeParametrizationOptions timing;       ///< control period and turn-radius safety factor
  double validation_terrain_step_m = 2.0;  ///< (0, 5]
  double speed_tolerance_m_s = 0.05;       ///< ≥ 0: speed/climb excess tolerated after rescaling

  static TrajectoryOptimizerOptions default_optimizer() {
    TrajectoryOptimizerOptions o;
    o.max_iterations = 100;
    return o;
  }
};

enum class LocalReplanStatus {
  kReplanned,          ///< `reference` replaces r over [t_0, t_1]; it passed the dense check
  kNoConflict,         ///< r already keeps R + r_safe from every threat over the window
  kThreatUnavoidable,  ///< a fixed point (r at t_0 or t_1) is inside a threat's swept sphere,
                       ///< or Ipopt proved the window infeasible; message says which
  kIterationLimit,     ///< Ipopt's iteration limit
  kTimeLimit,          ///< time_budget_s exhausted
  kValidationFailed,   ///< every round broke a hard constraint; message says which, when, where
  kSolverError,        ///< any other Ipopt failure
  kInvalidInput,       ///< message is "field: reason"
};
std::string_view to_string(LocalReplanStatus status);

struct LocalReplanResult {
  LocalReplanStatus status = LocalReplanStatus::kInvalidInput;
  std::string message;  ///< empty on success; else what failed, which constraint, where

  double window_start_s = 0.0;  ///< t_0
  double window_end_s = 0.0;    ///< t_1
  double time_step_s = 0.0;     ///< Δt of the grid
  /// kReplanned: the optimized waypoints at the grid times t_0 … t_1.
  TimedPath waypoints;
  /// kReplanned: the new reference over [t_0, t_1] (r(t_0) at t_0, r(t_1) at t_1).
  std::optional<mpc::SampledReference> reference;
  std::vector<double> sample_times_s;  ///< its samples (control period)
  std::vector<mpc::ReferencePoint> samples;

  // What the dense check measured on the returned reference (or r, for kNoConflict).
  double min_threat_distance_m = std::numeric_limits<double>::infinity();  ///< to the capsule − R
  double min_terrain_clearance_m = std::numeric_limits<double>::infinity();
  double min_separation_m = std::numeric_limits<double>::infinity();
  double join_gap_m = 0.0;    ///< |new(t_1) − r(t_1)| (0 up to round-off)
  double length_m = 0.0;      ///< 3-D length of the new reference over the window
  double old_length_m = 0.0;  ///< of r over the window

  int ipopt_iterations = 0;  ///< over all solves
  int solves = 0;
  int variables = 0;  ///< of the last NLP
  int constraints = 0;
  int obstacle_rows = 0;
  double solve_time_s = 0.0;  ///< Ipopt, all solves
  double total_time_s = 0.0;  ///< everything (setup, solves, parametrization, validation)

  bool ok() const { return status == LocalReplanStatus::kReplanned; }
};

/// Re-plans the UAV's reference over the window (file comment). Never throws on bad data.
LocalReplanResult replan_locally(const LocalReplanProblem& problem,
                                 const LocalReplanOptions& options = {});

}  // namespace ridgeline::planning
