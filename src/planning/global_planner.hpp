// The global cooperative planner (DESIGN §5, paper §2.4 "ground station"): from the team and
// the inspection targets to one validated reference trajectory r_i(t) per UAV.
//
// Pipeline, each stage a module of this folder:
//  1. target allocation (target_allocation.hpp) on terrain-aware cost estimates;
//  2. initial paths (path_search.hpp): Lazy Theta* over a clearance grid, altitude profile
//     within the pitch limit, densely verified;
//  3. joint optimization of all waypoints on a shared time grid (trajectory_optimizer.hpp,
//     eq. 14–24), when enabled;
//  4. time parametrization (time_parametrization.hpp) within the speed band, turn radius and
//     climb limit, sampled at the control period;
//  5. dense validation of every hard constraint on the final references: terrain clearance
//     (eq. 19–20), the altitude band (eq. 14) and the separation at equal times (eq. 21).
// A plan that fails stage 5 is never returned as planned: the status says which constraint
// failed where.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "planning/path_search.hpp"
#include "planning/target_allocation.hpp"
#include "planning/time_parametrization.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/terrain.hpp"

namespace ridgeline::planning {

struct PlannerUav {
  std::string name;
  Vec3 start_m = Vec3::Zero();
  double start_heading_rad = 0.0;
  vehicle::VehicleParams vehicle;
};

/// What the ground station knows before take-off (sudden threats are not part of it).
struct GlobalPlanningProblem {
  std::shared_ptr<const world::Terrain> terrain;
  SearchArea area;
  double min_altitude_m = 40.0;       ///< H_min, eq. 14
  double max_altitude_m = 500.0;      ///< H_max
  double terrain_clearance_m = 20.0;  ///< h_safe, eq. 19–20
  double separation_m = 10.0;         ///< d_safe, eq. 21
  std::vector<PlannerUav> uavs;
  std::vector<AllocationTarget> targets;
};

struct GlobalPlannerOptions {
  PathSearchOptions search;  ///< altitude band, clearance and pitch are taken from the problem
  AllocationOptions allocation;
  CostEstimateOptions cost_estimate;
  TimeParametrizationOptions timing;
  double validation_step_m = 2.0;  ///< terrain sampling along references, ≤ 5 m
};

enum class GlobalPlanStatus {
  kPlanned,           ///< every reference passed dense validation
  kInvalidInput,      ///< message: "field: reason"
  kUnreachable,       ///< a target or start cannot be reached; message names it
  kValidationFailed,  ///< a hard constraint fails on the final references; message says where
};
std::string_view to_string(GlobalPlanStatus status);

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
  double allocation_time_s = 0.0;
  double search_time_s = 0.0;
  double timing_time_s = 0.0;
  double validation_time_s = 0.0;
  double total_time_s = 0.0;
};

/// Plans the mission. Never throws on bad data: see status and message.
GlobalPlan plan_mission(const GlobalPlanningProblem& problem,
                        const GlobalPlannerOptions& options = {});

}  // namespace ridgeline::planning
