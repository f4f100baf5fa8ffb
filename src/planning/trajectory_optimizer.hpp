// Joint optimization of all UAVs' waypoints (DESIGN §5, paper eq. 14–24), solved with Ipopt,
// followed by a dense validation that cannot be skipped.
//
// Time grid and waypoints. All UAVs share the grid t_k = k·Δt. UAV i has waypoints
// p_{i,k} = (x, y, z), k = 0 … n_i, reached at t_k. Its initial path (from the path search) is
// timed at cruise: a segment of horizontal length ℓ and rise Δz takes max(ℓ/v0, |Δz|/w_max)
// (the climb limit slows steep parts). Δt = T_max / N, T_max the longest UAV's initial time and
// N = waypoints_per_uav (or Δt = time_step_s when set). Each leg between consecutive targets gets
// n_leg = max(1, round(T_leg/Δt)) segments, and the initial guess is the leg resampled at equal
// times, so every target lands on a grid index. p_{i,0} (start) and the waypoint of every target
// (intermediate and final) are fixed. A UAV that finishes early (n_i < max n) holds at its final
// point for the separation constraints (it loiters or lands there).
//
// Variables: all waypoints (3 per waypoint, fixed ones with equal bounds, which Ipopt removes),
// one pitch slack s^θ per segment and one turn slack s^φ per interior waypoint.
// Notation per segment k: d = p_{k+1} − p_k, h = √(d_x² + d_y² + ε²) (ε = 1e-3 m keeps every
// term smooth), L = √(h² + d_z²), ℓ_i = v0_i·Δt the nominal segment length; per interior waypoint
// k the horizontal turn angle φ_k between d_{k−1} and d_k, cos φ_k = a·b/(|a||b|) (norms with ε).
//
// Hard constraints:
//  (14)    H_min ≤ z_{i,k} ≤ H_max                                         (variable bounds)
//  (19–20) z − H(x, y) ≥ h_safe + e + m at every waypoint and at terrain_samples_per_segment
//          interior points (1−τ)p_k + τp_{k+1}, τ = j/(s+1); e = terrain.model_error_m(),
//          m = clearance_margin_m (covers the terrain's curvature between samples: for a peak of
//          height h and width σ, |H''| ≤ 2h/σ², so half a 10 m spacing sags ≤ h·25/σ² m; sharper
//          terrain is caught by the dense check and refined). Next to a fixed point the margin is
//          capped at that point's own slack, or the rows would be infeasible by construction.
//  (21)    |r|² ≥ (d_safe + separation_margin_m)², r = p_{i,k} − p_{j,k}, at every grid index of
//          a candidate pair, and at separation_samples_per_step interior times of each candidate
//          step (relative motion is linear in time on a step because the grid is shared).
//          Candidates: pairs/steps whose initial guesses come within separation_prefilter_m.
//  speed   ((v0 − Δv)·Δt)² ≤ d_x² + d_y² ≤ ((v0 + Δv)·Δt)², the speed band of eq. 2, so the
//          grid stays a valid timing; the lower bound is relaxed to half the guess's length where
//          the guess itself is slower (very short legs).
//  climb   |d_z| ≤ w_max·Δt (eq. 2), when enforce_climb_rate.
//  grade   G²·(d_x² + d_y²) − d_z² ≥ 0, i.e. |d_z| ≤ G·|d_xy| on the segment's actual horizontal
//          length, G = grade_fraction·min(tan θ_max, w_max/(v0 − Δv)): the pitch limit, and the
//          climb limit at the slowest speed the band allows (the speed band and the climb row
//          alone allow w_max/(v0 − Δv), above tan θ_max for the default vehicle, and the pitch
//          penalty below is soft and measured over ℓ). Added where a solution breaks it (see
//          "Validation and refinement"), so plans that never climb that steeply keep their NLP.
// Penalty rows (exact penalties of the non-smooth max terms, linear in the slacks):
//  (15–16) s^θ_k ≥ ±d_z/ℓ − tan θ_max, s^θ_k ≥ 0: s^θ is the grade in excess of tan θ_max, a
//          smooth surrogate of max(0, |θ| − θ_max) (tan is increasing, so both vanish together).
//          The grade is taken over the nominal horizontal length ℓ (the pitch flown at cruise
//          speed), not over h: with h the rows are non-convex (a lateral zig-zag lengthens h and
//          lowers the grade, "switchbacks"), and with the active multipliers of a steep initial
//          guess that negative curvature dominated the Hessian and cost hundreds of iterations.
//          When the climb limit already implies the pitch limit (w_max·Δt ≤ tan θ_max·ℓ, true for
//          the default vehicle: 3 m/s vs 10 m/s·tan 30°) the penalty is identically zero and its
//          slacks and rows are left out.
//  (17–18) s^φ_k ≥ cos φ_max − cos φ_k, s^φ_k ≥ 0: the excess of 1 − cos φ over 1 − cos φ_max,
//          a smooth surrogate of max(0, φ − φ_max).
// Costs (all in metres of "equivalent cruise distance", so the weights are unit-free):
//  (22)    J_L = Σ_k (I_k/I0)·L_k with the current model
//            I_k/I0 = 1 + κ_climb·σ(d_z)/L_k + κ_turn·½(τ_k + τ_{k+1}) + κ_speed·(h/ℓ − 1)²,
//          σ(d_z) = ½(d_z + √(d_z² + ε_c²)) the smooth max(d_z, 0), τ_k = 1 − cos φ_k (0 at the
//          ends): climbing costs κ_climb metres per metre gained, turning and off-cruise speed
//          raise the current in proportion.
//  (15–16) J_θ = Σ_k ℓ·((d_z/ℓ)² + K_θ·s^θ_k)        (tan²θ at cruise plus the penalty)
//  (17–18) J_φ = Σ_k ℓ·(1 − cos φ_k + K_φ·s^φ_k)
//          J_H = Σ_k ℓ·(z_k − H(x_k, y_k))/altitude_scale_m   (height above ground: stay low)
//  (23)    J_i = w1·J_L + w2·J_θ + w3·J_φ + w4·J_H
//  (24)    J = λ1·Σ_i J_i + λ2·J_col,  J_col = Σ_{candidates (i,j,k)} ℓ̄·max(0, 1 − |r|²/D_c²)²,
//          D_c = collision_soft_distance_m: a C¹ push apart beyond the hard d_safe.
// Derivatives: exact and sparse. Gradients and Jacobians of the geometric terms come from
// forward-mode automatic differentiation (ceres::Jet) of small element functions (one segment:
// 6 variables; one vertex: 9), terrain terms from Terrain::gradient. The Hessian of the
// Lagrangian is exact too (second-order forward AD of the same element functions; separation
// and J_col analytic), except ∇²H of the terrain, taken as central differences of
// Terrain::gradient (step 1e-3 m). By default (convexify_hessian) the Hessian handed to Ipopt is
// convexified element by element: each segment's 6×6 block, each vertex's 9×9 block, each
// terrain point's 2×2 block of ±λ∇²H, each collision pair's 3×3 block is replaced by its
// projection onto the positive semidefinite cone (negative eigenvalues set to 0), and a
// separation row's 2λ·I is dropped when λ < 0. The sum is positive semidefinite and differs from
// the exact Hessian only by added curvature. Gradients and Jacobians stay exact, so Ipopt's
// convergence test is unchanged and its solution is a KKT point of the same NLP; what changes is
// the Newton model: the exact one is indefinite almost everywhere (turn angles, −H in J_H,
// terrain and separation rows), Ipopt then needed 2–4 trial factorizations per iteration for
// its inertia correction and ~105 iterations on 3 × 100, against one factorization and ~58
// iterations convexified (it also found lower J on the ridge test: 2150 vs 2540). Ipopt's
// limited-memory quasi-Newton Hessian is an option, but with thousands of inequality rows its
// low-rank updates cost many back-solves per iteration and it needed more than 500 iterations
// on 3 × 100 (time limit).
// Rows in m² (speed band, separation) are scaled by 1/(2·length) for Ipopt (user scaling), so all
// rows read in metres near their bounds. Barrier update: monotone (adaptive measured slower here).
//
// Performance (2-core shared machine, Debian's Ipopt 3.11.9 with MUMPS 5.5 — no HSL solvers;
// `ridgeline bench plan`): the default scenario's 3 × 100 (1098 variables, 1401 rows) takes 58
// iterations of ~10 ms, about half in MUMPS (one factorization and ~3 back-solves each) and a
// third in the Hessian (the 9×9 vertex blocks and their projection); the whole plan_mission
// ≈ 0.6–0.7 s CPU. Before: exact indefinite Hessian, 104 iterations of 2–4 factorizations, the
// automatic MUMPS ordering and a mandatory refinement step, ≈ 2.5 s. Every separation row
// couples two UAVs and fills the KKT factor, so the candidate prefilter is kept tight (50 m:
// 150 m gave 2.7k rows and a time limit for 10 × 100); pairs it misses are added by the
// refinement.
//
// Validation and refinement. After every solve the waypoints with their times t_k are checked by
// validate_plan (plan_validation.hpp): terrain every ≤ 5 m, the altitude band, and separation at
// every control period (piecewise-linear positions; finished UAVs hold); and each UAV's path is
// timed as the planner will fly it (time_parametrize_timed with options.timing): a pitch or
// climb-rate violation gives that UAV the grade rows on every segment, or, if it had them, shrinks
// its G by the excess (its corners cut more than grade_fraction left); and those timed references
// get the same dense check as the waypoints (their rounded corners and timing errors move them
// off the straight, linearly timed segments: a separation row at d_safe + 0.5 m flew at 9.98 m),
// each violation refined on the grid step of its time. A violation refines the
// transcription: the offending segment gets twice the interior terrain samples and its margin
// grows by the violated amount; an offending pair/step becomes a candidate with twice the interior
// separation samples and a larger margin; the neighbouring segments of a terrain violation get
// twice the samples too (the re-solve may slide the waypoints so that the same peak falls on the
// next segment: without this, a field of 12 m-wide spikes needed 5 rounds). Then the problem is
// re-solved from the last solution, warm-started: the multipliers of the rows the two NLPs
// share (matched by TrajectoryNlp::row_key) and of the bounds, barrier parameter warm_start_mu.
// After max_refinements rounds that still fail, the result is kValidationFailed with the
// violation's constraint, UAV(s), time and place — and no waypoints. A path that breaks a hard
// constraint is never returned.
#pragma once

#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/types.hpp"
#include "planning/guess_deconfliction.hpp"
#include "planning/plan_validation.hpp"
#include "planning/time_parametrization.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"

namespace ridgeline::planning {

/// One UAV's input: its initial path and where its targets are on it.
struct TrajectoryUav {
  std::string name;
  std::vector<Vec3> initial_path_m;  ///< start first, ≥ 2 points, e.g. PathResult::waypoints_m
  /// Indices into initial_path_m of the targets in visiting order (strictly increasing, > 0);
  /// the last must be the path's last point. Empty: the last point is the only target.
  std::vector<int> target_indices;
  vehicle::VehicleParams vehicle;  ///< v0, Δv, w_max, θ_max are used
};

struct TrajectoryProblem {
  const world::Terrain* terrain = nullptr;  ///< must outlive the call; the dense check's
  /// The terrain of the NLP's rows when set (must outlive the call): a smooth model of
  /// `terrain` whose model_error_m() bounds how far `terrain` rises above it
  /// (world/smooth_terrain.hpp), so its rows keep h_safe above `terrain`. Null: `terrain`.
  const world::Terrain* optimization_terrain = nullptr;
  world::SafetyLimits limits;               ///< H_min, H_max, h_safe, d_safe (eq. 14, 19–21)
  std::vector<TrajectoryUav> uavs;
};

/// kSparseLdlt: our fixed-order LDLᵀ (kkt_ldlt.hpp), several times faster per iteration on
/// these systems; kMumps: Debian Ipopt's MUMPS, the reference.
enum class KktFactorization { kSparseLdlt, kMumps };

/// How a team is optimized (priority_decomposition.hpp): all UAVs in one NLP, or one UAV at a
/// time in priority order against the fixed references of those before it; kAuto: joint up to
/// joint_max_uavs UAVs.
enum class TeamDecomposition { kAuto, kJoint, kPriority };

struct TrajectoryOptimizerOptions {
  // Grid.
  int waypoints_per_uav = 100;  ///< N: segments of the longest UAV (≥ 2), when time_step_s ≤ 0
  double time_step_s = 0.0;     ///< Δt if > 0 (overrides waypoints_per_uav)
  // Hard constraints: the limits are the problem's; these are how they become rows.
  double clearance_margin_m = 1.0;       ///< m ≥ 0 added to the clearance rows
  double separation_margin_m = 0.5;      ///< ≥ 0 added to d_safe in the separation rows
  int terrain_samples_per_segment = 1;   ///< ≥ 0 interior clearance points per segment
  int separation_samples_per_step = 1;   ///< ≥ 0 interior separation times per candidate step
  double separation_prefilter_m = 50.0;  ///< candidate pairs: guesses within this distance
                                         ///< (misses are caught by the dense check and added)
  bool enforce_climb_rate = true;        ///< |d_z| ≤ w_max·Δt
  /// G = this × the flyable grade min(tan θ_max, w_max/(v0 − Δv)) bounds every segment's grade
  /// |d_z|/|d_xy| (file comment, "grade"); in (0, 1]: the rest is room for the corners the time
  /// parametrization rounds (each steepens its stretch by the length its arc cuts).
  double grade_fraction = 0.95;
  /// Separation-aware initial guess (guess_deconfliction.hpp): before the first solve, UAVs
  /// whose resampled initial paths come closer than guess_separation_factor·d_safe at equal
  /// times are lifted into altitude layers (shortest routes first; only z is raised, within the
  /// climb limit, H_max, and never at a fixed start or target).
  /// Off by default: on the default terrain with 10 UAVs × 100 waypoints it left Ipopt needing
  /// more iterations, not fewer (573 off, 723 at factor 1.5, 1604 at 2; README, "Global planner
  /// scaling"): the layers cost climb energy that the optimizer then undoes.
  bool deconflict_guesses = false;
  double guess_separation_factor = 1.5;  ///< ≥ 1 (D = max(this·d_safe, d_safe + margin))
  // Penalties and weights (eq. 15–18, 23–24); defaults are the default scenario's.
  double max_turn_angle_rad = deg_to_rad(60.0);  ///< φ_max; θ_max comes from each vehicle
  double pitch_penalty = 100.0;                  ///< K_θ
  double turn_penalty = 100.0;                   ///< K_φ
  double weight_range = 1.0;                     ///< w1
  double weight_pitch = 1.0;                     ///< w2
  double weight_turn = 1.0;                      ///< w3
  double weight_altitude = 0.1;                  ///< w4
  double lambda_individual = 1.0;                ///< λ1
  double lambda_collision = 10.0;                ///< λ2
  double collision_soft_distance_m = 30.0;       ///< D_c > d_safe
  double altitude_scale_m = 100.0;               ///< J_H normalization (> 0)
  // Current model of eq. 22, relative to the cruise current I0.
  double climb_current = 5.0;  ///< κ_climb ≥ 0: metres of cruise per metre climbed
  double turn_current = 0.5;   ///< κ_turn ≥ 0
  double speed_current = 1.0;  ///< κ_speed ≥ 0
  // Team decomposition (priority_decomposition.hpp).
  TeamDecomposition decomposition = TeamDecomposition::kAuto;
  int joint_max_uavs = 6;  ///< kAuto: the joint NLP up to this many UAVs (≥ 1)
  int threads = 2;         ///< ≥ 1: UAVs solved at once by the priority decomposition
  /// > 0: the priority decomposition couples a UAV to the earlier ones whose guesses come this
  /// close at equal grid times (their references are its obstacles).
  double coupling_distance_m = 150.0;
  /// The decomposition's obstacle rows (eq. 21 against fixed references): at every sample of a
  /// step where the UAV's current point comes within this of an earlier UAV's reference, and
  /// on every step that ever had rows (a refinement never drops one). Constant rows do not
  /// couple UAVs, so this can be wider than separation_prefilter_m: with 50 m, 100 UAVs' solves
  /// slid onto neighbours' paths where the guess had no rows, one step a round.
  double obstacle_prefilter_m = 80.0;
  // Solver.
  double tolerance = 1e-5;             ///< Ipopt tol
  double constraint_tolerance = 1e-6;  ///< Ipopt constr_viol_tol (m or m²)
  int max_iterations = 500;            ///< per solve (at least iterations_per_uav × UAVs)
  /// ≥ 0: the per-solve limit grows with the team, max(max_iterations, this × UAVs): more UAVs
  /// start closer together and couple through more separation rows, and Ipopt needs more
  /// iterations to pull them apart (10 UAVs × 100 waypoints on the default terrain: ~1600 over
  /// 4 solves, where 500 stopped the first solve).
  int iterations_per_uav = 200;
  int max_refinements = 3;        ///< re-solves after a failed validation
  /// The decomposition's re-solves of one UAV (its NLP is small, a round cheap): each round
  /// may meet another of the fixed references its last solve moved next to (100 UAVs: up to 6).
  int uav_max_refinements = 8;
  /// ≥ 0: per UAV, the earlier UAVs it may take priority over when it cannot be solved against
  /// them (each then yields: re-solved against the whole team; priority_decomposition.hpp).
  int max_priority_swaps = 2;
  /// CPU seconds of the optimizing threads (core/cpu_clock.hpp, CpuBudget): setup, solves and
  /// checks; the same plan on a loaded machine. Running out is kTimeLimit, never another plan.
  double time_budget_s = 20.0;
  bool adaptive_barrier = false;  ///< Ipopt mu_strategy adaptive (else monotone: measured
                                  ///< fewer, cheaper iterations on these problems)
  bool exact_hessian = true;      ///< false: Ipopt's limited-memory quasi-Newton
  /// Ipopt's second-order corrections of rejected steps (its default). Off: on 40 test
  /// problems (1–4 UAVs, 20–80 waypoints, two terrains) they made Ipopt cycle between a near
  /// solution and a corrected jump away in 10 problems; without them all 40 solved in 36 % of
  /// the iterations.
  bool second_order_corrections = false;
  /// The factorization of Ipopt's KKT system at each iteration.
  KktFactorization kkt_factorization = KktFactorization::kSparseLdlt;
  /// With exact_hessian: each element's block of the Hessian of the Lagrangian (segment, vertex,
  /// terrain point, separation row, collision pair) projected onto the positive semidefinite
  /// cone (file comment). The gradients and Jacobians stay exact, so a point Ipopt accepts is a
  /// KKT point of the same NLP; only the Newton model changes.
  bool convexify_hessian = true;
  int lbfgs_history = 10;  ///< limited_memory_max_history (exact_hessian = false)
  int print_level = 0;     ///< Ipopt print_level (0: silent, 5: per iteration)
  /// Refinement re-solves start from the last solution's primal point and multipliers (rows
  /// the refinement added start at zero) with barrier parameter warm_start_mu, instead of
  /// restarting the barrier at its default 0.1.
  bool warm_start_refinements = true;
  double warm_start_mu = 1e-3;
  /// The timing that will fly the waypoints (time_parametrization.hpp, timed mode): a solution
  /// it cannot fly within a UAV's pitch or climb limit gets grade rows (file comment).
  TimeParametrizationOptions timing;
  // Validation (plan_validation.hpp).
  double validation_terrain_step_m = 2.0;        ///< ≤ 5
  double validation_separation_period_s = 0.02;  ///< the control period
};

enum class TrajectoryStatus {
  kSolved,                 ///< solved; the first solution passed dense validation
  kSolvedAfterRefinement,  ///< passed after ≥ 1 refinement round
  kInfeasible,             ///< no feasible plan (Ipopt, or fixed points that violate eq. 21)
  kIterationLimit,         ///< Ipopt's iteration limit
  kTimeLimit,              ///< time_budget_s exhausted
  kInvalidInput,           ///< message is "field: reason"
  kValidationFailed,       ///< every round broke a hard constraint; message says where
  kSolverError,            ///< any other Ipopt failure
};
std::string_view to_string(TrajectoryStatus status);

/// Cost terms of one UAV at the solution (eq. 15–23), metres-equivalent, before λ1.
struct UavCost {
  double range = 0.0;          ///< J_L
  double pitch = 0.0;          ///< J_θ (including the penalty)
  double pitch_penalty = 0.0;  ///< its part ℓ·K_θ·Σ s^θ
  double turn = 0.0;           ///< J_φ (including the penalty)
  double turn_penalty = 0.0;   ///< its part ℓ·K_φ·Σ s^φ
  double altitude = 0.0;       ///< J_H
  double total = 0.0;          ///< J_i = w1 J_L + w2 J_θ + w3 J_φ + w4 J_H
  double length_m = 0.0;       ///< 3-D length of the waypoint polyline
  double max_pitch_rad = 0.0;  ///< max |atan(d_z/h)| over segments
  double max_turn_rad = 0.0;   ///< max φ_k
};

struct TrajectoryResult {
  TrajectoryStatus status = TrajectoryStatus::kInvalidInput;
  std::string message;  ///< empty on success; else what failed, which constraint, where

  double time_step_s = 0.0;      ///< Δt of the shared grid
  std::vector<TimedPath> paths;  ///< per UAV: waypoints at t_k = k·Δt; empty on failure
  std::vector<UavCost> costs;    ///< per UAV (filled on success)
  double collision_cost = 0.0;   ///< J_col
  double objective = 0.0;        ///< J of eq. 24
  /// The same terms at the initial guess (the initial paths resampled on the grid), for
  /// comparison; filled once the grid is built, also when the solve fails.
  std::vector<UavCost> initial_costs;
  double initial_collision_cost = 0.0;
  double initial_objective = 0.0;
  PlanValidationReport validation;  ///< of the last solution that was validated
  /// Per UAV, `paths` timed with options.timing (time_parametrize_timed), as checked: the
  /// references the planner flies (filled on success).
  std::vector<TimeParametrizationResult> timing;
  /// The separation-aware guess (deconflict_guesses): separations before and after, lifts.
  GuessDeconflictionSummary guess;

  /// True when the team was optimized one UAV at a time (priority_decomposition.hpp): then
  /// J and the initial J have no J_col term, and solves counts every UAV's solves.
  bool decomposed = false;
  /// Decomposed: UAVs whose last solve stopped at Ipopt's iteration limit and whose iterate then
  /// passed the dense check (validated, not proved optimal).
  int feasible_stops = 0;
  /// Decomposed: pairs where a UAV took priority over the earlier one it could not be solved
  /// against (which then yielded).
  int priority_swaps = 0;
  int ipopt_iterations = 0;  ///< over all solves
  int solves = 0;            ///< 1 + refinement rounds used
  int variables = 0;         ///< of the last NLP (including fixed waypoints)
  int constraints = 0;
  int separation_rows = 0;
  double solve_time_s = 0.0;  ///< Ipopt, all solves
  double total_time_s = 0.0;  ///< everything, including setup and validation

  bool ok() const {
    return status == TrajectoryStatus::kSolved ||
           status == TrajectoryStatus::kSolvedAfterRefinement;
  }
};

/// Optimizes all UAVs' waypoints jointly (file comment). Never throws on bad data: see status.
TrajectoryResult optimize_trajectories(const TrajectoryProblem& problem,
                                       const TrajectoryOptimizerOptions& options = {});

}  // namespace ridgeline::planning
