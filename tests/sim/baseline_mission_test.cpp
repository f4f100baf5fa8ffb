// The comparison methods flown through the shared mission loop (issue 6): each baseline plans
// and flies a small scenario to its targets without touching the terrain, through the same
// truth simulator, transport and metrics as the proposed method; method names parse, and an
// unknown one is one clear error.
#include <gtest/gtest.h>

#include "core/error.hpp"
#include "sim/method.hpp"
#include "sim/mission.hpp"
#include "support/small_mission.hpp"
#include "world/terrain.hpp"

namespace ridgeline::sim {
namespace {

using test::small_scenario;

class BaselineMission : public ::testing::TestWithParam<Method> {};

TEST_P(BaselineMission, FliesToEveryTargetWithoutTerrainCollision) {
  std::shared_ptr<const world::Terrain> terrain;
  const mission::Scenario s = small_scenario(terrain, true);
  const planning::GlobalPlan plan = plan_for_method(s, terrain, GetParam());
  ASSERT_EQ(plan.status, planning::GlobalPlanStatus::kPlanned) << plan.message;
  MissionOptions options;
  options.method = GetParam();
  const mission::MissionResult r = fly_mission(s, terrain, plan, options);
  const mission::MissionMetrics& m = r.metrics;
  EXPECT_TRUE(m.mission_complete) << to_json(m).dump(2);
  EXPECT_EQ(m.terrain_collisions, 0);
  EXPECT_EQ(m.constraint_violations.at("altitude"), 0);
  EXPECT_EQ(m.constraint_violations.at("turn"), 0);
  ASSERT_EQ(m.uavs.size(), 2u);
  for (const mission::UavMetrics& u : m.uavs) {
    EXPECT_EQ(u.targets_inspected, 1);
    EXPECT_GE(u.min_terrain_clearance_m, s.safety.terrain_clearance_m) << u.name;
    // Each flew at least the straight-line distance to its target (≈ 690 m) and not wildly more.
    EXPECT_GT(u.path_length_m, 650.0);
    EXPECT_LT(u.path_length_m, 1200.0);
    EXPECT_GT(u.tracking_samples, 40);
  }
  // Control step times are measured for every method (the MPC step, the DWA, the follower).
  EXPECT_GT(m.mpc_solve_us.max, 0.0);
  // The trajectory log measures the baseline against its own timed reference.
  ASSERT_FALSE(r.trajectories.empty());
  EXPECT_LT((r.trajectories.front().reference_m - s.uavs[0].start_position_m).norm(), 15.0);
}

INSTANTIATE_TEST_SUITE_P(Methods, BaselineMission,
                         ::testing::Values(Method::kAstarDwa, Method::kWindAware),
                         [](const auto& info) { return std::string(to_string(info.param)); });

// [8]: the committed DDPG policy (models/) flies the same small mission through the same loop.
TEST(DdpgMission, TheCommittedPolicyFliesToEveryTargetWithinTheLimits) {
  std::shared_ptr<const world::Terrain> terrain;
  const mission::Scenario s = small_scenario(terrain, true);
  const planning::GlobalPlan plan = plan_for_method(s, terrain, Method::kDdpg);
  ASSERT_EQ(plan.status, planning::GlobalPlanStatus::kPlanned) << plan.message;
  MissionOptions options;
  options.method = Method::kDdpg;
  try {
    fly_mission(s, terrain, plan, options);
    FAIL() << "flew without a policy";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "--ddpg-model");
  }
  options.ddpg_policy = std::make_shared<const learning::DdpgPolicy>(
      learning::DdpgPolicy::load(RIDGELINE_SOURCE_DIR "/models/ddpg_mountain.pt"));
  const mission::MissionMetrics m = fly_mission(s, terrain, plan, options).metrics;
  EXPECT_TRUE(m.mission_complete) << to_json(m).dump(2);
  EXPECT_EQ(m.terrain_collisions, 0);
  EXPECT_EQ(m.threat_intrusions, 0);
  // The command is mapped into the maneuver limits and the climb kept within the pitch limit.
  EXPECT_EQ(m.constraint_violations.at("altitude"), 0);
  EXPECT_EQ(m.constraint_violations.at("turn"), 0);
  EXPECT_EQ(m.constraint_violations.at("pitch"), 0);
  for (const mission::UavMetrics& u : m.uavs) {
    EXPECT_EQ(u.targets_inspected, 1) << u.name;
    EXPECT_GT(u.path_length_m, 600.0) << u.name;  // at least about the straight line
  }
}

TEST(Method, NamesRoundTripAndAnUnknownOneIsAClearError) {
  for (const Method m : all_methods()) EXPECT_EQ(parse_method(to_string(m)), m);
  try {
    parse_method("dqn");
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--method"), std::string::npos) << what;
    EXPECT_NE(what.find("'dqn'"), std::string::npos) << what;
    EXPECT_NE(what.find("astar_dwa"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace ridgeline::sim
