// Joint trajectory optimization (src/planning/trajectory_optimizer.hpp) on the default-like
// terrain: 3 UAVs × 100 waypoints (the paper's case: CasADi SQP 4–6 s), and 10 and 30 UAVs at
// 100 and 200 waypoints. Initial guesses are straight lines lifted above the terrain
// (planning/team_scenarios.hpp). Run with --benchmark_repetitions=5
// --benchmark_report_aggregates_only=true for medians. Counters: Ipopt iterations, solves,
// NLP size, and whether the result passed the dense validation (1) or not (0).
#include <benchmark/benchmark.h>

#include "planning/team_scenarios.hpp"
#include "planning/trajectory_optimizer.hpp"

namespace {

using namespace ridgeline::planning;

void BM_OptimizeTeam(benchmark::State& state) {
  const auto terrain = default_like_terrain();
  const TrajectoryProblem problem = straight_line_team(terrain, static_cast<int>(state.range(0)));
  TrajectoryOptimizerOptions options;
  options.waypoints_per_uav = static_cast<int>(state.range(1));
  options.time_budget_s = 120.0;
  options.max_iterations = 3000;
  TrajectoryResult result;
  for (auto _ : state) {
    result = optimize_trajectories(problem, options);
    benchmark::DoNotOptimize(result.objective);
  }
  state.counters["ok"] = result.ok() ? 1.0 : 0.0;
  state.counters["iterations"] = result.ipopt_iterations;
  state.counters["solves"] = result.solves;
  state.counters["variables"] = result.variables;
  state.counters["rows"] = result.constraints;
  state.counters["separation_rows"] = result.separation_rows;
  state.counters["min_clearance_m"] = result.validation.min_clearance_m;
  state.counters["min_separation_m"] = result.validation.min_separation_m;
  if (!result.ok()) state.SetLabel(std::string(to_string(result.status)));
}

BENCHMARK(BM_OptimizeTeam)
    ->Args({3, 100})
    ->Args({10, 100})
    ->Args({10, 200})
    ->Args({30, 100})
    ->Args({30, 200})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
