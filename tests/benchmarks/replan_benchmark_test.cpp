// The re-plan benchmark's bookkeeping (not its speed: speed is measured by `ridgeline bench
// replan`, never asserted in a test): every case is counted under exactly one status, times
// are reported only over the cases that ran the optimizer, the re-planned cases keep their
// margins, and the same seed gives the same cases.
#include "benchmarks/replan_benchmark.hpp"

#include <gtest/gtest.h>

#include <memory>

#include "core/error.hpp"
#include "planning/team_scenarios.hpp"

namespace ridgeline::benchmarks {
namespace {

planning::GlobalPlanningProblem small_problem() {
  planning::GlobalPlanningProblem p;
  p.terrain = std::make_shared<world::PeakTerrain>(planning::default_like_terrain());
  p.area.min_m = Vec2(0.0, 0.0);
  p.area.max_m = Vec2(2000.0, 2000.0);
  const Vec3 starts[] = {{100, 130, 60}, {130, 100, 60}, {160, 70, 60}};
  for (int i = 0; i < 3; ++i)
    p.uavs.push_back({"uav" + std::to_string(i + 1), starts[i], kPi / 4, vehicle::VehicleParams{}});
  p.targets = {{"mast", Vec3(1700, 1300, 90), 2},
               {"ridge", Vec3(1250, 1800, 110), 1},
               {"hut", Vec3(1850, 1850, 80), 1}};
  return p;
}

planning::GlobalPlannerOptions small_options() {
  planning::GlobalPlannerOptions o;
  o.optimizer.waypoints_per_uav = 20;
  return o;
}

TEST(ReplanBenchmark, CountsEveryCaseOnceAndTimesOnlyOptimizedCases) {
  ReplanBenchmarkOptions o;
  o.cases = 8;
  o.seed = 3;
  o.replan.time_budget_s = 30.0;  // statuses independent of the machine's load
  const ReplanBenchmarkReport a = run_replan_benchmark(small_problem(), small_options(), o);
  int total = 0;
  for (const auto& [status, n] : a.status_counts) {
    EXPECT_NE(status, "invalid input");
    total += n;
  }
  EXPECT_EQ(total, 8);
  EXPECT_EQ(a.cases, 8);
  EXPECT_LE(a.optimized, 8);
  const int replanned = a.status_counts.count("replanned") ? a.status_counts.at("replanned") : 0;
  EXPECT_LE(replanned, a.optimized);
  EXPECT_GT(replanned, 0) << "random threats across open routes are mostly avoidable";
  EXPECT_GT(a.replan_cpu_ms.median, 0.0);
  EXPECT_LE(a.replan_ms.median, a.replan_ms.max);
  EXPECT_GE(a.ipopt_iterations.median, 1.0);
  // The dense check's guarantees on every re-planned window (1e-6: its own tolerance).
  EXPECT_GE(a.min_threat_distance_m, world::SafetyLimits{}.threat_margin_m - 1e-6);
  EXPECT_GE(a.min_separation_m, 10.0 - 1e-6);
  EXPECT_GE(a.min_terrain_clearance_m, 20.0 - 1e-6);
  EXPECT_GT(a.mean_detour_ratio, 1.0);
  // Same seed, same cases: the same statuses (times differ).
  const ReplanBenchmarkReport b = run_replan_benchmark(small_problem(), small_options(), o);
  EXPECT_EQ(a.status_counts, b.status_counts);
  EXPECT_EQ(a.ipopt_iterations.max, b.ipopt_iterations.max);
}

TEST(ReplanBenchmark, RejectsBadOptions) {
  ReplanBenchmarkOptions o;
  o.cases = 0;
  EXPECT_THROW(run_replan_benchmark(small_problem(), small_options(), o), InputError);
}

}  // namespace
}  // namespace ridgeline::benchmarks
