// The planner benchmark's bookkeeping (not its speed: speed is measured by `ridgeline bench
// plan`, never asserted in a test): rows for the requested sizes, each saying honestly how its
// plan ended, for teams of the sizes it claims.
#include "benchmarks/plan_benchmark.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <set>

#include "core/error.hpp"
#include "planning/team_scenarios.hpp"

namespace ridgeline::benchmarks {
namespace {

// The default scenario's team and targets on the default-like terrain, at a test-sized grid.
struct Base {
  mission::Scenario scenario;
  std::shared_ptr<const world::Terrain> terrain =
      std::make_shared<world::PeakTerrain>(planning::default_like_terrain());
};

Base small_base() {
  Base b;
  const Vec3 starts[] = {{100, 130, 60}, {130, 100, 60}, {160, 70, 60}};
  for (int i = 0; i < 3; ++i) {
    mission::UavSpec u;
    u.name = "uav" + std::to_string(i + 1);
    u.start_position_m = starts[i];
    u.start_heading_rad = kPi / 4;
    b.scenario.uavs.push_back(u);
  }
  b.scenario.targets = {{"mast", Vec3(1700, 1300, 90), 2, 30.0},
                        {"ridge", Vec3(1250, 1800, 110), 1, 30.0},
                        {"hut", Vec3(1850, 1850, 80), 1, 30.0}};
  b.scenario.planner.waypoints_per_uav = 20;
  return b;
}

TEST(PlanBenchmark, ReportsOneRowPerSizeWithTheSizeItPlannedAndHowItEnded) {
  PlanBenchmarkOptions options;
  options.repeats = 2;
  options.uav_counts = {3, 4};
  options.waypoint_counts = {20, 24};
  options.scaling_time_budget_s = 5.0;  // keeps the test short if a row's optimizer struggles
  const Base base = small_base();
  const PlanBenchmarkReport report = run_plan_benchmark(base.scenario, base.terrain, options);
  EXPECT_EQ(report.base.uavs, 3);
  EXPECT_EQ(report.base.waypoints, 20);
  EXPECT_GT(report.base.plan_s.median, 0.0);
  EXPECT_GT(report.base.plan_cpu_s.median, 0.0);
  EXPECT_LE(report.base.plan_s.median, report.base.plan_s.max);
  ASSERT_EQ(report.scaling.size(), 4u);
  std::set<std::pair<int, int>> sizes;
  for (const PlanScalingRow& row : report.scaling) {
    sizes.insert({row.uavs, row.waypoints});
    EXPECT_EQ(row.targets, row.uavs);
    EXPECT_EQ(row.status, "planned") << row.message;
    // Whatever the optimizer did, the row says which paths fly, and a fallback gives its reason.
    if (row.path_source == "optimized") {
      EXPECT_TRUE(row.optimizer_status == "solved" ||
                  row.optimizer_status == "solved after refinement")
          << row.optimizer_status;
      EXPECT_GT(row.ipopt_iterations, 0);
      EXPECT_LT(row.objective, row.initial_objective);
    } else {
      EXPECT_EQ(row.path_source, "initial paths (optimizer failed)");
      EXPECT_FALSE(row.optimizer_message.empty());
    }
    // Dense validation of what flies (the same floors as the problem's).
    EXPECT_GE(row.min_clearance_m, 20.0);
    EXPECT_GE(row.min_separation_m, 10.0);
    const nlohmann::json j = row.to_json();
    EXPECT_EQ(j.at("uavs"), row.uavs);
    EXPECT_EQ(j.at("path_source"), row.path_source);
  }
  EXPECT_EQ(sizes, (std::set<std::pair<int, int>>{{3, 20}, {3, 24}, {4, 20}, {4, 24}}));
  const nlohmann::json j = report.to_json();
  EXPECT_EQ(j.at("plan_s").at("median"), report.base.plan_s.median);
  EXPECT_EQ(j.at("scaling").size(), 4u);
}

TEST(PlanBenchmark, BadOptionsNameTheField) {
  const Base base = small_base();
  PlanBenchmarkOptions options;
  options.repeats = 0;
  EXPECT_THROW(run_plan_benchmark(base.scenario, base.terrain, options), InputError);
  options.repeats = 1;
  options.scaling_repeats = -1;
  EXPECT_THROW(run_plan_benchmark(base.scenario, base.terrain, options), InputError);
}

}  // namespace
}  // namespace ridgeline::benchmarks
