// The comparison methods' offline planners: paths reach their targets, keep the terrain
// clearance and the pitch limit everywhere (dense check, independent of the planner's own
// validation), go around terrain above H_max, smoothing recovers the straight line on open
// ground, and an unreachable target is named.
#include "baselines/baseline_planner.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "planning/path_search.hpp"
#include "world/terrain.hpp"

namespace ridgeline::baselines {
namespace {

planning::GlobalPlanningProblem hill_problem(std::shared_ptr<const world::Terrain> terrain) {
  planning::GlobalPlanningProblem p;
  p.terrain = std::move(terrain);
  p.area.min_m = Vec2(0, 0);
  p.area.max_m = Vec2(1000, 1000);
  p.uavs = {{"u0", Vec3(100, 100, 60), kPi / 4, {}}, {"u1", Vec3(100, 160, 60), kPi / 4, {}}};
  p.targets = {{"a", Vec3(850, 800, 80), 1}, {"b", Vec3(800, 900, 80), 1}};
  return p;
}

std::shared_ptr<const world::Terrain> one_hill() {
  world::PeakTerrainConfig peaks;
  peaks.peaks = {{480, 480, 400, 120, 120}};  // above H_max: must be flown around
  return std::make_shared<world::PeakTerrain>(peaks);
}

TEST(BaselinePlanner, BothMethodsReachTheirTargetsAboveTheTerrainWithinThePitchLimit) {
  const auto terrain = one_hill();
  for (const BaselinePathMethod method :
       {BaselinePathMethod::kImprovedAStar, BaselinePathMethod::kWindAware}) {
    BaselinePlannerOptions o;
    o.method = method;
    o.forecast_wind_m_s = Vec3(3, 0, 0);
    const planning::GlobalPlan plan = plan_baseline_mission(hill_problem(terrain), o);
    ASSERT_EQ(plan.status, planning::GlobalPlanStatus::kPlanned) << plan.message;
    ASSERT_EQ(plan.uavs.size(), 2u);
    for (const planning::UavPlan& u : plan.uavs) {
      ASSERT_EQ(u.targets.size(), 1u);
      const Vec3 target =
          hill_problem(terrain).targets[static_cast<std::size_t>(u.targets[0])].position_m;
      EXPECT_LT((u.waypoints_m.back() - target).norm(), 1e-6);
      // Independent dense check of the timed reference every ≤ 1 m.
      std::vector<Vec3> flown;
      for (const auto& s : u.timing.samples) flown.push_back(s.position_m);
      const planning::PathCheck check = planning::check_path(*terrain, flown, 1.0);
      EXPECT_GE(check.min_clearance_m, 20.0 - 1e-6) << to_string(method);
      EXPECT_GE(check.min_altitude_m, 40.0);
      EXPECT_LE(check.max_altitude_m, 500.0);
      // The profile's grade is ≤ 0.8 tan 30°; corner arcs may add a little (the time
      // parametrization spreads the length an arc cuts over its stretch), so allow the hard
      // limit itself.
      EXPECT_LE(check.max_pitch_rad, deg_to_rad(30.0) + 1e-6);
      // Around the hill, not over it: nothing above the hill's flanks' altitude band.
      for (const Vec3& p : u.waypoints_m) EXPECT_GT((p.head<2>() - Vec2(480, 480)).norm(), 150.0);
    }
  }
}

// On open flat ground the 8-connected grid path zig-zags; smoothing must recover the straight
// segment from start to target exactly.
TEST(BaselinePlanner, SmoothingRecoversTheStraightLineOnOpenGround) {
  world::PeakTerrainConfig flat;
  flat.peaks = {{500, 500, 1, 10, 10}};
  const auto terrain = std::make_shared<world::PeakTerrain>(flat);
  planning::GlobalPlanningProblem p = hill_problem(terrain);
  p.uavs.resize(1);
  p.targets.resize(1);
  BaselinePlannerOptions o;
  const planning::GlobalPlan plan = plan_baseline_mission(p, o);
  ASSERT_EQ(plan.status, planning::GlobalPlanStatus::kPlanned) << plan.message;
  double horizontal = 0.0;
  const auto& w = plan.uavs[0].waypoints_m;
  for (std::size_t k = 1; k < w.size(); ++k) horizontal += (w[k] - w[k - 1]).head<2>().norm();
  const double straight = (p.targets[0].position_m - p.uavs[0].start_m).head<2>().norm();
  EXPECT_NEAR(horizontal, straight, 1e-6 * straight + 1e-3);
}

TEST(BaselinePlanner, UnreachableTargetIsReportedByName) {
  world::PeakTerrainConfig ring;
  for (double a = 0; a < 2 * kPi; a += kPi / 12)
    ring.peaks.push_back({800 + 120 * std::cos(a), 800 + 120 * std::sin(a), 700, 40, 40});
  const auto terrain = std::make_shared<world::PeakTerrain>(ring);
  planning::GlobalPlanningProblem p = hill_problem(terrain);
  p.uavs.resize(1);
  p.targets = {{"walled", Vec3(800, 800, 60), 1}};
  const planning::GlobalPlan plan = plan_baseline_mission(p, {});
  EXPECT_EQ(plan.status, planning::GlobalPlanStatus::kUnreachable);
  EXPECT_NE(plan.message.find("walled"), std::string::npos) << plan.message;
}

}  // namespace
}  // namespace ridgeline::baselines
