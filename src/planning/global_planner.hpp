// The global cooperative planner (DESIGN §5, paper §2.4 "ground station"): from the team and
// the inspection targets to one validated reference trajectory r_i(t) per UAV.
//
// Pipeline, each stage a module of this folder:
//  1. target allocation (target_allocation.hpp) on terrain-aware cost estimates;
//  2. initial paths (path_search.hpp): Lazy Theta* over a clearance grid, altitude profile
//     within the pitch limit, densely verified;
//  3. joint optimization of all waypoints on a shared time grid (trajectory_optimizer.hpp,
//     eq. 14–24), when enabled: the initial paths and the indices of the targets on them are
//     its input and initial guess;
//  4. time parametrization (time_parametrization.hpp) within the speed band, turn radius and
//     climb limit, sampled at the control period. Optimized waypoints are timed in timed mode
//     (each waypoint passed at its grid time t_k, so the separations planned at equal times,
//     eq. 21, stay valid); initial paths at cruise;
//  5. dense validation of every hard constraint on the final references: terrain clearance
//     (eq. 19–20), the altitude band (eq. 14) and the separation at equal times (eq. 21).
// A plan that fails stage 5 is never returned as planned: the status says which constraint
// failed where.
//
// Stage 3 can fail (Ipopt stops, its time budget runs out, its result breaks a limit in stage 4
// or a hard constraint in stage 5). With OptimizerFallback::kInitialPaths (the default) the plan
// then flies the initial paths, timed and validated by stages 4–5 on their own, and says so:
// path_source is kInitialPathsOptimizerFailed and optimizer_message gives the reason. With
// kFail the plan fails with that reason (constraint and place).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "planning/path_search.hpp"
#include "planning/target_allocation.hpp"
#include "planning/time_parametrization.hpp"
#include "planning/trajectory_optimizer.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/terrain.hpp"

namespace ridgeline::planning {

struct PlannerUav {
  std::string name;
  Vec3 start_m = Vec3::Zero();
  double start_heading_rad = 0.0;
  vehicle::VehicleParams vehicle;
  /// Targets (indices into the problem's) only this UAV may visit; allocation keeps them on
  /// its route. A target required of two UAVs is invalid input.
  std::vector<int> required_targets = {};
  /// Where the UAV flies after its last target, the path's fixed last point (a UAV with an
  /// end and no target flies straight there); none: its path ends at its last target.
  std::optional<Vec3> end_m = std::nullopt;
};

/// What the ground station knows before take-off (sudden threats are not part of it).
struct GlobalPlanningProblem {
  std::shared_ptr<const world::Terrain> terrain;
  SearchArea area;
  world::SafetyLimits limits;  ///< the band (eq. 14), h_safe (eq. 19–20), d_safe (eq. 21)
  std::vector<PlannerUav> uavs;
  std::vector<AllocationTarget> targets;
};

/// What plan_mission does when stage 3 fails or its result fails stage 4 or 5.
enum class OptimizerFallback {
  kInitialPaths,  ///< fly the (validated) initial paths; path_source says so
  kFail,          ///< fail: status kOptimizationFailed, message names constraint and place
};

struct GlobalPlannerOptions {
  /// θ_max (atan of optimizer.grade_fraction × the team's flyable grade, min(tan θ_max,
  /// w_max/(v0 − Δv))) and the turn margin are taken from the team's vehicles.
  PathSearchOptions search;
  AllocationOptions allocation;
  CostEstimateOptions cost_estimate;
  bool optimize = true;  ///< stage 3 (joint optimization, eq. 14–24) on or off
  /// Stage 3. The validation steps are taken from validation_step_m and
  /// timing.control_period_s, its timing check from timing; the rest (grid, weights w1..w4, λ1, λ2, penalties, solver limits)
  /// as given. The limits are the problem's.
  TrajectoryOptimizerOptions optimizer;
  OptimizerFallback on_optimizer_failure = OptimizerFallback::kInitialPaths;
  TimeParametrizationOptions timing;
  double validation_step_m = 2.0;  ///< terrain sampling along references, ≤ 5 m
};

enum class GlobalPlanStatus {
  kPlanned,           ///< every reference passed dense validation
  kInvalidInput,      ///< message: "field: reason"
  kUnreachable,       ///< a target or start cannot be reached; message names it
  kValidationFailed,  ///< a hard constraint fails on the final references; message says where
  kOptimizationFailed,  ///< stage 3 failed and on_optimizer_failure is kFail; message says why
};
std::string_view to_string(GlobalPlanStatus status);

/// Which waypoints the references follow.
enum class PathSource {
  kOptimized,                    ///< stage 3's jointly optimized waypoints
  kInitialPathsOptimizerOff,     ///< the initial paths: stage 3 is disabled
  kInitialPathsOptimizerFailed,  ///< the initial paths: stage 3 failed (optimizer_message)
};
std::string_view to_string(PathSource source);

/// Minimum distances found by the dense validation of the final references.
struct PlanValidationSummary {
  double min_terrain_clearance_m = 0.0;  ///< min over all UAVs of z − H(x, y)
  double min_altitude_m = 0.0;
  double max_altitude_m = 0.0;
  double min_separation_m = 0.0;         ///< min over pairs at equal times (∞ for one UAV)
  double max_pitch_rad = 0.0;
  int samples_checked = 0;
};

struct UavPlan {
  std::string name;
  std::vector<int> targets;           ///< indices into the problem's targets, in visiting order
  std::vector<Vec3> waypoints_m;      ///< the validated polyline (start first)
  TimeParametrizationResult timing;   ///< holds the reference r_i(t) and its samples
};

struct GlobalPlan {
  GlobalPlanStatus status = GlobalPlanStatus::kInvalidInput;
  std::string message;
  std::vector<UavPlan> uavs;
  AllocationResult allocation;
  PlanValidationSummary validation;
  PathSource path_source = PathSource::kInitialPathsOptimizerOff;
  /// Stage 3's result when it ran (its costs per UAV, J, iterations, times; its paths are the
  /// optimized waypoints on the grid, whether or not they were used).
  std::optional<TrajectoryResult> optimization;
  /// Empty when the optimized waypoints were used or stage 3 was off; else why they were not
  /// (the optimizer's status and message, or the limit/constraint they broke in stage 4–5).
  std::string optimizer_message;
  double allocation_time_s = 0.0;
  double search_time_s = 0.0;
  double optimization_time_s = 0.0;
  double timing_time_s = 0.0;
  double validation_time_s = 0.0;
  double total_time_s = 0.0;
};

/// The allocation problem of `problem` (its UAVs' starts, required targets and ends, its targets)
/// with the terrain-aware cost estimates; the one both the proposed and the baseline planners
/// allocate on. Throws InputError naming a bad cost-estimate option.
AllocationProblem make_allocation_problem(const GlobalPlanningProblem& problem,
                                          const CostEstimateOptions& options);

/// Plans the mission. Never throws on bad data: see status and message.
GlobalPlan plan_mission(const GlobalPlanningProblem& problem,
                        const GlobalPlannerOptions& options = {});

}  // namespace ridgeline::planning
