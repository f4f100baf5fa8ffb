// The global planner on scenarios: the default one and variations of it.
#include "mission/stage_inputs.hpp"

#include <gtest/gtest.h>

#include "world/terrain.hpp"

namespace ridgeline::mission {
namespace {

// A small copy of the default scenario's geometry, built in code (the io layer that parses
// the YAML sits above this one).
struct Fixture {
  mission::Scenario scenario;
  std::shared_ptr<const world::Terrain> terrain;
};

Fixture default_like() {
  Fixture f;
  world::PeakTerrainConfig peaks;
  peaks.peaks = {{600, 700, 220, 180, 150},  {1100, 450, 160, 150, 200},
                 {900, 1250, 300, 200, 170}, {1500, 1000, 250, 170, 220},
                 {400, 1500, 120, 150, 150}, {1400, 1600, 180, 160, 140},
                 {1800, 300, 80, 120, 120}};
  f.terrain = std::make_shared<world::PeakTerrain>(peaks);
  const Vec3 starts[] = {{100, 130, 60}, {130, 100, 60}, {160, 70, 60}};
  for (int i = 0; i < 3; ++i) {
    mission::UavSpec u;
    u.name = "uav" + std::to_string(i + 1);
    u.start_position_m = starts[i];
    u.start_heading_rad = kPi / 4;
    f.scenario.uavs.push_back(u);
  }
  f.scenario.targets = {{"mast", Vec3(1700, 1300, 90), 2, 30},
                        {"ridge", Vec3(1250, 1800, 110), 1, 30},
                        {"hut", Vec3(1850, 1850, 80), 1, 30}};
  return f;
}

TEST(MissionPlanning, DefaultLikeScenarioIsPlannedAndValidated) {
  const Fixture f = default_like();
  const planning::GlobalPlan plan =
      planning::plan_mission(mission::make_planning_problem(f.scenario, f.terrain),
                             mission::make_planner_options(f.scenario));
  ASSERT_EQ(plan.status, planning::GlobalPlanStatus::kPlanned) << plan.message;
  ASSERT_EQ(plan.uavs.size(), 3u);  // one target each
  EXPECT_GE(plan.validation.min_terrain_clearance_m, 20.0 - 1e-6);
  EXPECT_GE(plan.validation.min_separation_m, 10.0 - 1e-6);
  EXPECT_LE(plan.validation.max_altitude_m, 500.0 + 1e-6);
  EXPECT_GE(plan.validation.min_altitude_m, 40.0 - 1e-6);
  for (const planning::UavPlan& uav : plan.uavs) {
    ASSERT_EQ(uav.targets.size(), 1u);
    // The reference passes its target: the inspection radius is 30 m.
    const Vec3 target = f.scenario.targets[static_cast<std::size_t>(uav.targets[0])].position_m;
    double closest = 1e9;
    for (const auto& s : uav.timing.samples)
      closest = std::min(closest, (s.position_m - target).norm());
    EXPECT_LT(closest, 1.0) << uav.name;
  }
}

TEST(MissionPlanning, ScenarioPlannerWeightsReachTheOptimizer) {
  mission::Scenario s;
  s.planner.waypoints_per_uav = 77;
  s.planner.max_turn_angle_rad = 0.9;
  s.planner.pitch_penalty = 11.0;
  s.planner.turn_penalty = 12.0;
  s.planner.weight_range = 1.5;
  s.planner.weight_pitch = 2.5;
  s.planner.weight_turn = 3.5;
  s.planner.weight_altitude = 4.5;
  s.planner.lambda_individual = 5.5;
  s.planner.lambda_collision = 6.5;
  const planning::TrajectoryOptimizerOptions o = mission::make_planner_options(s).optimizer;
  EXPECT_EQ(o.waypoints_per_uav, 77);
  EXPECT_EQ(o.max_turn_angle_rad, 0.9);
  EXPECT_EQ(o.pitch_penalty, 11.0);
  EXPECT_EQ(o.turn_penalty, 12.0);
  EXPECT_EQ(o.weight_range, 1.5);
  EXPECT_EQ(o.weight_pitch, 2.5);
  EXPECT_EQ(o.weight_turn, 3.5);
  EXPECT_EQ(o.weight_altitude, 4.5);
  EXPECT_EQ(o.lambda_individual, 5.5);
  EXPECT_EQ(o.lambda_collision, 6.5);
  EXPECT_TRUE(mission::make_planner_options(s).optimize);
  s.planner.allocation_makespan_weight = 7.5;
  s.planner.allocation_priority_weight = 0.25;
  const planning::AllocationOptions a = mission::make_planner_options(s).allocation;
  EXPECT_EQ(a.makespan_weight, 7.5);
  EXPECT_EQ(a.priority_weight, 0.25);
}

TEST(MissionPlanning, UnreachableTargetIsNamed) {
  Fixture f = default_like();
  // A ring of peaks taller than the altitude ceiling around the hut.
  world::PeakTerrainConfig peaks = static_cast<const world::PeakTerrain&>(*f.terrain).config();
  for (int k = 0; k < 12; ++k) {
    const double a = 2 * kPi * k / 12;
    peaks.peaks.push_back({1700 + 120 * std::cos(a), 1700 + 120 * std::sin(a), 700, 50, 50});
  }
  f.terrain = std::make_shared<world::PeakTerrain>(peaks);
  f.scenario.targets[2].position_m = Vec3(1700, 1700, 80);
  const planning::GlobalPlan plan =
      planning::plan_mission(mission::make_planning_problem(f.scenario, f.terrain),
                             mission::make_planner_options(f.scenario));
  EXPECT_EQ(plan.status, planning::GlobalPlanStatus::kUnreachable);
  EXPECT_NE(plan.message.find("hut"), std::string::npos) << plan.message;
  EXPECT_TRUE(plan.uavs.empty());
}

}  // namespace
}  // namespace ridgeline::mission
