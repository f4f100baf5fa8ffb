// Offline path planners of the comparison methods (paper §3, refs. [6] and [7]; issue 6):
// the same target allocation as the proposed planner (planning/target_allocation.hpp, on the
// same terrain-aware cost estimates), then per UAV, independently of the others:
//
//  [7] improved A*: A* over the clearance grid (planning/path_search.hpp's ClearanceGrid,
//      8-connected) whose state is (cell, heading of the last move), edge cost
//        c = √(L² + Δz²) + k_climb·max(0, Δz) + k_turn·|Δχ|,
//      Δz the change of the cells' required altitude z_req, Δχ the heading change (a
//      multiple of 45°). Heuristic: the horizontal distance (admissible). Then smoothing:
//      redundant nodes are removed greedily — from each kept node, the farthest later node
//      reachable by a straight segment whose cells are all passable and whose cost is no
//      larger than the path it replaces.
//  [6] wind-aware offline optimization: the same search and smoothing with the edge cost
//        J = w_t·t + w_e·E + w_l·Λ,
//      t = ℓ / v_g the flight time with the ground speed v_g = W·d + √(v0² − |W × d|²) of a
//      UAV flying at cruise airspeed v0 along direction d in the forecast (mean) wind W;
//      E = k_W·t + c_climb·max(0, Δz) the energy in seconds of cruise power, where the
//      wind-influence coefficient k_W = 1 + c_W·max(0, −W·d)/v0 raises the power needed against
//      a headwind and c_climb = g/(η·p0) converts the climb's potential energy (η = 0.7,
//      p0 = 150 W/kg specific cruise power of a hexacopter); Λ = |Δχ| + |Δz|/ℓ the load of
//      turning and climbing (rad). Heuristic: w_t·d/(v0 + |W|) (admissible).
//
// Both then give the horizontal polyline an altitude profile: sampled every profile_step_m,
// the floor is q(s) = max(H_min + pad_H, H + h_safe + e + pad, min(z_req, cone(s))) with the cones
// z_p + m·|s − s_p| of the start and targets (so a target's altitude stays reachable), and the
// profile is the lowest function above q with slope ≤ m = pitch_use·tan θ_max (two passes).
// The waypoints are timed at cruise speed (planning/time_parametrization.hpp) and validated
// densely for terrain clearance and the altitude band. Separation between UAVs is not
// planned: both methods plan each UAV alone (the A* + DWA agents keep it on line).
#pragma once

#include <string_view>
#include <vector>

#include "planning/global_planner.hpp"

namespace ridgeline::baselines {

enum class BaselinePathMethod {
  kImprovedAStar,  ///< [7]
  kWindAware,      ///< [6]
};
std::string_view to_string(BaselinePathMethod method);

struct BaselinePlannerOptions {
  BaselinePathMethod method = BaselinePathMethod::kImprovedAStar;
  planning::PathSearchOptions search;  ///< grid; altitude band, clearance, pitch from the problem
  planning::AllocationOptions allocation;
  planning::CostEstimateOptions cost_estimate;
  planning::TimeParametrizationOptions timing;
  double climb_penalty = 1.0;             ///< k_climb (A*), per metre climbed
  double turn_penalty_m = 20.0;           ///< k_turn (A*), metres per radian of heading change
  Vec3 forecast_wind_m_s = Vec3::Zero();  ///< W (wind-aware): the forecast mean wind
  double weight_time = 1.0;               ///< w_t (wind-aware)
  double weight_energy = 1.0;             ///< w_e
  double weight_load = 2.0;               ///< w_l, seconds per radian of load
  double wind_influence = 1.0;            ///< c_W
  double climb_energy_s_per_m = 9.81 / (0.7 * 150.0);  ///< c_climb = g/(η·p0)
  double profile_step_m = 5.0;                         ///< (0, 5]
  double profile_pad_m = 1.0;                          ///< ≥ 0, over the hard floor
  double pitch_use = 0.8;       ///< (0, 1]: the profile's slope is at most this × tan θ_max
  double altitude_pad_m = 5.0;  ///< ≥ 0: the profile stays this far above H_min (room for
                                ///< the follower's altitude error)
  double validation_step_m = 2.0;
};

/// Plans every UAV's path with the chosen baseline. The result has the proposed planner's
/// shape (allocation, per-UAV waypoints and timed reference, times); path_source is
/// kInitialPathsOptimizerOff and `optimization` empty. Never throws on bad data.
planning::GlobalPlan plan_baseline_mission(const planning::GlobalPlanningProblem& problem,
                                           const BaselinePlannerOptions& options);

}  // namespace ridgeline::baselines
