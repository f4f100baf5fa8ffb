// The optimizer's priority decomposition (priority_decomposition.hpp): one UAV at a time against
// the others' fixed references, never returning a team that breaks eq. 21, and the same result
// whatever the number of threads.
#include "planning/priority_decomposition.hpp"

#include <gtest/gtest.h>

#include "planning/plan_validation.hpp"
#include "planning/team_scenarios.hpp"

namespace ridgeline::planning {
namespace {

// The flown references (what stage 4 hands the tracker), checked independently and finer than
// the optimizer's own check (2 m, 0.02 s).
PlanValidationReport check_flown_references(const world::Terrain& terrain, const TrajectoryResult& r,
                                            const world::SafetyLimits& limits) {
  std::vector<TimedPath> flown;
  for (std::size_t i = 0; i < r.timing.size(); ++i) {
    TimedPath p;
    p.name = r.paths[i].name;
    p.times_s = r.timing[i].sample_times_s;
    for (const auto& s : r.timing[i].samples) p.waypoints_m.push_back(s.position_m);
    flown.push_back(std::move(p));
  }
  PlanValidationOptions v;
  v.terrain_step_m = 0.5;
  v.separation_period_s = 0.005;
  return validate_plan(terrain, flown, limits, v);
}

TEST(PriorityDecomposition, TwoUavsCrossingAtTheSameTimeAreKeptApart) {
  // Flat ground; the two straight routes cross at (400, 400) at the same time.
  world::PeakTerrainConfig flat;
  flat.peaks = {{5000.0, 5000.0, 10.0, 100.0, 100.0}};
  const world::PeakTerrain terrain(flat);
  TrajectoryProblem problem;
  problem.terrain = &terrain;
  const Vec3 a0(0, 0, 60), a1(800, 800, 60), b0(800, 0, 60), b1(0, 800, 60);
  problem.uavs.push_back({"a", lifted_line(terrain, a0, a1), {}, {}});
  problem.uavs.push_back({"b", lifted_line(terrain, b0, b1), {}, {}});
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 40;
  o.decomposition = TeamDecomposition::kPriority;
  const TrajectoryResult r = optimize_trajectories(problem, o);
  ASSERT_TRUE(r.ok()) << to_string(r.status) << ": " << r.message;
  EXPECT_TRUE(r.decomposed);
  ASSERT_EQ(r.paths.size(), 2u);
  ASSERT_EQ(r.timing.size(), 2u);
  EXPECT_GT(r.separation_rows, 0);  // the crossing needed obstacle rows
  const PlanValidationReport check = check_flown_references(terrain, r, problem.limits);
  EXPECT_TRUE(check.passed()) << check.summary();
  EXPECT_GE(check.min_separation_m, problem.limits.separation_m);
}

TEST(PriorityDecomposition, AUavBoxedInByAnEarlierOneTakesPriorityAndTheOtherYields) {
  // Flat ground. "fast" (first in order: same grid, lower index) flies east through the start
  // of "slow", a sluggish vehicle heading west: 100 m apart, closing at ~13 m/s, and slow can
  // move neither 10.5 m sideways (R_min 80 m) nor up (0.5 m/s) in the ~8 s before they meet,
  // so against fast's fixed reference it has no solution. Fast can dodge it: slow takes
  // priority and fast yields (re-solved against slow).
  world::PeakTerrainConfig flat;
  flat.peaks = {{5000.0, 5000.0, 10.0, 100.0, 100.0}};
  const world::PeakTerrain terrain(flat);
  TrajectoryProblem problem;
  problem.terrain = &terrain;
  const Vec3 fast0(0, 400, 60), fast1(400, 400, 60), slow0(100, 400, 60), slow1(-800, 400, 60);
  problem.uavs.push_back({"fast", lifted_line(terrain, fast0, fast1), {}, {}});
  vehicle::VehicleParams sluggish;
  sluggish.cruise_speed_m_s = 4.0;
  sluggish.speed_band_m_s = 1.0;
  sluggish.min_turn_radius_m = 80.0;
  sluggish.max_climb_rate_m_s = 0.5;
  problem.uavs.push_back({"slow", lifted_line(terrain, slow0, slow1), {}, sluggish});
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 60;
  o.decomposition = TeamDecomposition::kPriority;
  const TrajectoryResult r = optimize_trajectories(problem, o);
  ASSERT_TRUE(r.ok()) << to_string(r.status) << ": " << r.message;
  EXPECT_EQ(r.priority_swaps, 1);
  const PlanValidationReport check = check_flown_references(terrain, r, problem.limits);
  EXPECT_TRUE(check.passed()) << check.summary();
  EXPECT_GE(check.min_separation_m, problem.limits.separation_m);
  // Without the swap the plan fails, naming the two.
  o.max_priority_swaps = 0;
  const TrajectoryResult fixed_order = optimize_trajectories(problem, o);
  EXPECT_FALSE(fixed_order.ok());
  EXPECT_NE(fixed_order.message.find("slow"), std::string::npos) << fixed_order.message;
}

TEST(PriorityDecomposition, ATeamIsValidatedAndTheSameOnOneOrTwoThreads) {
  const world::PeakTerrain terrain = default_like_terrain();
  const TrajectoryProblem problem = straight_line_team(terrain, 8);
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 80;
  o.decomposition = TeamDecomposition::kPriority;
  o.threads = 1;
  const TrajectoryResult one = optimize_trajectories(problem, o);
  o.threads = 2;
  const TrajectoryResult two = optimize_trajectories(problem, o);
  ASSERT_TRUE(one.ok()) << one.message;
  ASSERT_TRUE(two.ok()) << two.message;
  ASSERT_EQ(one.paths.size(), 8u);
  for (std::size_t i = 0; i < one.paths.size(); ++i)
    EXPECT_EQ(one.paths[i].waypoints_m, two.paths[i].waypoints_m) << i;
  EXPECT_LT(two.objective, two.initial_objective);
  EXPECT_EQ(two.costs.size(), 8u);
  const PlanValidationReport check = check_flown_references(terrain, two, problem.limits);
  EXPECT_TRUE(check.passed()) << check.summary();
}

TEST(PriorityDecomposition, AutoKeepsTheJointNlpForSmallTeams) {
  const world::PeakTerrain terrain = default_like_terrain();
  const TrajectoryProblem problem = straight_line_team(terrain, 3);
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 50;
  const TrajectoryResult joint = optimize_trajectories(problem, o);
  ASSERT_TRUE(joint.ok()) << joint.message;
  EXPECT_FALSE(joint.decomposed);
  o.joint_max_uavs = 2;
  const TrajectoryResult split = optimize_trajectories(problem, o);
  ASSERT_TRUE(split.ok()) << split.message;
  EXPECT_TRUE(split.decomposed);
  o.threads = 0;
  EXPECT_EQ(optimize_trajectories(problem, o).status, TrajectoryStatus::kInvalidInput);
}

}  // namespace
}  // namespace ridgeline::planning
