// The local re-plan's workload for `ridgeline bench replan` (issue 4, item 6: "fast enough to
// run on board, target under 100 ms"): the base problem (the default scenario) is planned once
// with plan_mission, then `cases` randomized sudden threats are thrown at it, each at one
// UAV's reference, and planning::replan_locally re-plans that UAV's window against the threat
// and the other UAVs' references.
//
// A case (seeded, reproducible): a UAV i and a start time t_0 uniform over its reference (at
// least 10 s before its end), a crossing time t_c = t_0 + U(8, 25) s (before the end), a radius
// R ~ U(30, 60) m and speed |v_T| ~ U(2, 8) m/s (DESIGN §7's threats), a direction at a uniform
// angle to the reference's heading at t_c; the threat appears at t_0 and its centre passes r_i(t_c)
// at t_c, so every case is a real conflict unless the sweep misses the route.
//
// Each re-plan is timed in wall-clock time and in the calling thread's CPU time (robust to other
// load on a shared machine; what an on-board computer would spend). The times are reported over
// the cases that ran the optimizer (`optimized`: a result other than no-conflict and the
// immediate unavoidable verdict), with counts of every status, so a fast failure is never
// mistaken for a fast re-plan.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "mission/statistics.hpp"
#include "planning/global_planner.hpp"
#include "planning/local_replan.hpp"

namespace ridgeline::benchmarks {

struct ReplanBenchmarkOptions {
  int cases = 200;         ///< randomized threats (≥ 1)
  std::uint64_t seed = 1;  ///< of the cases
  /// The re-plan's options; its altitude band, h_safe and d_safe come from the problem.
  planning::LocalReplanOptions replan;
};

struct ReplanBenchmarkReport {
  int cases = 0;
  int optimized = 0;                                  ///< cases that ran Ipopt
  std::map<std::string, int> status_counts;           ///< LocalReplanStatus text → cases
  std::map<std::string, std::string> first_messages;  ///< failure status → its first message
  mission::Percentiles replan_ms;                     ///< wall clock, over the optimized cases
  mission::Percentiles replan_cpu_ms;                 ///< thread CPU time, over the optimized cases
  mission::Percentiles ipopt_iterations;
  mission::Percentiles solves;
  double min_threat_distance_m = 0.0;  ///< over replanned cases (≥ r_safe by the dense check)
  double min_separation_m = 0.0;       ///< over replanned cases
  double min_terrain_clearance_m = 0.0;
  double mean_detour_ratio = 0.0;  ///< mean new/old window length over replanned cases
  double plan_s = 0.0;             ///< the base plan's wall time
  std::string window;              ///< the options in words
  nlohmann::json to_json() const;
};

/// Plans `problem` with `planner` (must end kPlanned, else InputError "scenario" with the plan's
/// message) and runs the cases. Throws InputError on bad options.
ReplanBenchmarkReport run_replan_benchmark(const planning::GlobalPlanningProblem& problem,
                                           const planning::GlobalPlannerOptions& planner,
                                           const ReplanBenchmarkOptions& options = {});

}  // namespace ridgeline::benchmarks
