// The joint optimizer's decomposition for large teams (issue 20; trajectory_optimizer.hpp holds
// the NLP, eq. 14–24): one UAV at a time, in priority order, each against the fixed references
// of the UAVs before it that it may meet, so the cost grows about linearly with the team instead
// of with the joint KKT system's fill.
//
// Order. By route length on the shared grid (shortest first; ties by index), so a UAV that has
// finished and holds at its last point is always fixed before the UAVs still flying around it:
// their NLPs avoid it; it never has to avoid them.
//
// One UAV's NLP is the joint NLP of that UAV alone (its costs eq. 15–23, speed band, climb and
// grade limits, band eq. 14, terrain rows eq. 19–20) plus constant obstacle rows
// (trajectory_nlp.hpp, ObstacleRow) for eq. 21: at grid time t = (k + τ)·Δt its point keeps
// d_safe + separation_margin_m (+ refinement) from each earlier UAV's flown reference at t, on
// the steps where the current iterate comes within obstacle_prefilter_m of it (τ = 0 and
// separation_samples_per_step interior times per step); a step that had rows keeps them in
// every later round, so a re-solve cannot slide back into a conflict the last one left. The
// others' J_col is left out: the decomposed J is Σ_i λ1·J_i.
//
// Coupling and threads. UAV i depends on the earlier UAVs whose guesses come within
// coupling_m of its guess at some grid time; only those are its obstacles, so the result does
// not depend on which other UAVs happen to be finished. options.threads workers take the first
// UAV in order whose dependencies are done, so uncoupled UAVs are solved at the same time.
//
// Priority swaps. A UAV that cannot be solved against an earlier one — its route or its hold
// at the target boxed in by that UAV's reference, so Ipopt stops infeasible or every
// refinement is still too close — is solved again without that blocker (it takes priority,
// at most max_priority_swaps blockers a UAV), and the blocker yields: the team check below
// re-solves it, not the later UAV, against every other. A failure does not stop the pass:
// every UAV that does not depend on a failed one is solved and the first failure in order is
// reported, so the result does not depend on the threads.
//
// Validation. Each UAV's solution is timed as it will be flown (time_parametrize_timed) and
// checked densely like the joint one (terrain every ≤ 5 m, the band, its pitch and climb) and
// its reference against its obstacles' references at every control period; a violation refines
// that UAV's rows (more samples, a larger margin) and it is re-solved, warm-started, up to
// uav_max_refinements times. Then every pair of the whole team is checked (validate_plan); a pair
// that breaks eq. 21 — two UAVs that were not coupled by their guesses but met — has its later
// UAV re-solved against every other UAV, and the team is checked again. A team that still fails
// is kValidationFailed with the violation; nothing that breaks a hard constraint is returned.
#pragma once

#include <chrono>

#include "core/cpu_clock.hpp"
#include "planning/trajectory_optimizer.hpp"
#include "planning/trajectory_team_grid.hpp"

namespace ridgeline::planning::detail {

/// Optimizes `team` (its guesses already built, deconflicted and checked for fixed-point
/// conflicts) one UAV at a time (file comment). `result` carries the grid step and the guess
/// summary; its total (wall) time runs from `start`, its solves spend `budget` (each worker
/// thread charges its own CPU time).
TrajectoryResult optimize_in_priority_order(const TrajectoryProblem& problem,
                                            const TrajectoryOptimizerOptions& options,
                                            const TeamGrid& team, TrajectoryResult result,
                                            std::chrono::steady_clock::time_point start,
                                            CpuBudget& budget);

}  // namespace ridgeline::planning::detail
