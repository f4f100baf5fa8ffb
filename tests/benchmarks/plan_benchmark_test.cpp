// The planner benchmark's bookkeeping (not its speed: speed is measured by `ridgeline bench
// plan`, never asserted in a test): rows for the requested sizes, each saying honestly how its
// plan ended, and the scaled teams it plans are the sizes it claims.
#include "benchmarks/plan_benchmark.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <set>

#include "core/error.hpp"
#include "planning/team_scenarios.hpp"

namespace ridgeline::benchmarks {
namespace {

// The default scenario's team and targets on the default-like terrain, at a test-sized grid.
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

TEST(PlanBenchmark, ReportsOneRowPerSizeWithTheSizeItPlannedAndHowItEnded) {
  PlanBenchmarkOptions options;
  options.repeats = 2;
  options.uav_counts = {3, 4};
  options.waypoint_counts = {20, 24};
  options.scaling_time_budget_s = 5.0;  // keeps the test short if a row's optimizer struggles
  const PlanBenchmarkReport report = run_plan_benchmark(small_problem(), small_options(), options);
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

TEST(PlanBenchmark, ScaledTeamsOfThirtyFitTheAreaApartFromEachOther) {
  const planning::GlobalPlanningProblem base = small_problem();
  const planning::GlobalPlanningProblem p = planning::scaled_team(base, 30);
  ASSERT_EQ(p.uavs.size(), 30u);
  ASSERT_EQ(p.targets.size(), 30u);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(p.uavs[i].start_m, base.uavs[i].start_m);
  for (std::size_t i = 0; i < p.uavs.size(); ++i) {
    const Vec3& s = p.uavs[i].start_m;
    EXPECT_GE(s.z() - p.terrain->height(s.x(), s.y()), p.limits.terrain_clearance_m)
        << p.uavs[i].name;
    EXPECT_TRUE(s.x() >= p.area.min_m.x() && s.x() <= p.area.max_m.x() &&
                s.y() >= p.area.min_m.y() && s.y() <= p.area.max_m.y())
        << p.uavs[i].name;
    for (std::size_t j = i + 1; j < p.uavs.size(); ++j)
      EXPECT_GE((p.uavs[j].start_m - s).norm(), 2.0 * p.limits.separation_m)
          << p.uavs[i].name << " " << p.uavs[j].name;
  }
}

TEST(PlanBenchmark, BadOptionsNameTheField) {
  PlanBenchmarkOptions options;
  options.repeats = 0;
  EXPECT_THROW(run_plan_benchmark(small_problem(), small_options(), options), InputError);
  options.repeats = 1;
  options.scaling_repeats = -1;
  EXPECT_THROW(run_plan_benchmark(small_problem(), small_options(), options), InputError);
}

}  // namespace
}  // namespace ridgeline::benchmarks
