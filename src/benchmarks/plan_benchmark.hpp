// The global planner's workload for `ridgeline bench plan` (issue 4, item 8; issue 20): the full
// plan_mission (allocation, initial paths, Ipopt optimization eq. 14–24 — joint for small teams,
// in priority order for large ones — time parametrization, dense validation) on a base scenario —
// the default at its 3 UAVs × 100 waypoints — timed `repeats` times, then a scaling table of
// realistic teams on the same terrain and area: mission::make_team_scenario with N UAVs on a
// take-off grid and N targets spread over the area (seed team_seed), N = 3, 10, 30, 100, at 100
// and 200 waypoints.
//
// Each plan is timed whole, in wall-clock time (plan_s, what the target is about) and in
// process CPU time (plan_cpu_s: robust to other load on a shared machine). Every row says how the
// plan ended: its status, which waypoints it flies (path_source: "optimized", or the initial
// paths when the optimizer failed, with the optimizer's reason) and the optimizer's own status,
// so a fast row that fell back is never mistaken for a fast optimization.
#pragma once

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mission/scenario.hpp"
#include "mission/statistics.hpp"
#include "planning/global_planner.hpp"

namespace ridgeline::benchmarks {

struct PlanBenchmarkOptions {
  int repeats = 5;  ///< timed plans of the base problem (≥ 1)
  std::vector<int> uav_counts = {3, 10, 30, 100};
  std::vector<int> waypoint_counts = {100, 200};
  int scaling_repeats = 1;  ///< timed plans per scaling row (0: no table)
  /// Optimizer time budget per plan in the scaling rows (TrajectoryOptimizerOptions::
  /// time_budget_s); a row that runs out says so (path_source, optimizer_status).
  double scaling_time_budget_s = 60.0;
  std::uint64_t team_seed = 1;  ///< the scaling rows' team scenarios (targets, threats)
};

/// One plan_mission call, summarized.
struct PlanRun {
  double plan_s = 0.0;      ///< wall clock of plan_mission
  double plan_cpu_s = 0.0;  ///< process CPU time of plan_mission
  planning::GlobalPlan plan;
};

struct PlanScalingRow {
  int uavs = 0;
  int waypoints = 0;
  int targets = 0;
  mission::Percentiles plan_s;
  mission::Percentiles plan_cpu_s;
  double optimizer_s = 0.0;  ///< stage 3 of the last run (setup, Ipopt, its validation)
  double ipopt_s = 0.0;      ///< Ipopt alone, all solves
  int ipopt_iterations = 0;
  int solves = 0;  ///< 1 + refinement rounds (decomposed: summed over the UAVs)
  bool decomposed = false;  ///< optimized one UAV at a time (priority_decomposition.hpp)
  int priority_swaps = 0;   ///< decomposed: UAVs moved before the one they failed against
  int variables = 0;
  int constraints = 0;
  int separation_rows = 0;
  std::string status;              ///< GlobalPlanStatus text
  std::string path_source;         ///< PathSource text
  std::string optimizer_status;    ///< TrajectoryStatus text ("" when stage 3 did not run)
  std::string message;             ///< why the plan failed (empty when planned)
  std::string optimizer_message;   ///< why the optimized waypoints were not flown (or "")
  double objective = 0.0;          ///< J of eq. 24 at the optimizer's result (0 on failure)
  double initial_objective = 0.0;  ///< J at the initial paths on the same grid
  /// The optimizer's separation-aware guess: minimum separation at equal times of the initial
  /// paths on the grid before and after the altitude layering, and the conflicts left.
  double guess_separation_before_m = 0.0;
  double guess_separation_after_m = 0.0;
  int guess_conflicts_before = 0;
  int guess_conflicts_after = 0;
  double min_clearance_m = 0.0;  ///< dense validation of the flown references
  double min_separation_m = 0.0;
  double stage_s[5] = {};  ///< allocation, initial paths, optimization, timing, validation
  nlohmann::json to_json() const;
};

struct PlanBenchmarkReport {
  PlanScalingRow base;  ///< the base problem over `repeats` runs
  std::vector<PlanScalingRow> scaling;
  nlohmann::json to_json() const;  ///< {"plan_s": {...}, "plan_cpu_s", ..., "scaling": [...]}
};

/// Times plan_mission once on `problem` with `options`.
PlanRun time_plan(const planning::GlobalPlanningProblem& problem,
                  const planning::GlobalPlannerOptions& options);

/// Runs `runs` timed plans and summarizes them (the last run's details).
PlanScalingRow measure_plan(const planning::GlobalPlanningProblem& problem,
                            const planning::GlobalPlannerOptions& options, int runs);

/// The whole benchmark on a base scenario (e.g. the default) and its terrain. Throws InputError on
/// bad options or a team the generator cannot build.
PlanBenchmarkReport run_plan_benchmark(const mission::Scenario& base,
                                       std::shared_ptr<const world::Terrain> terrain,
                                       const PlanBenchmarkOptions& options = {});

}  // namespace ridgeline::benchmarks
