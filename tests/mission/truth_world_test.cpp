#include "mission/truth_world.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ridgeline::mission {
namespace {

mission::Scenario one_uav_scenario() {
  mission::Scenario s;
  mission::UavSpec u;
  u.name = "a";
  u.start_position_m = Vec3(100, 100, 100);
  u.start_heading_rad = 0.0;
  u.start_speed_m_s = 10.0;
  u.sensor_range_m = 100.0;
  s.uavs.push_back(u);
  s.wind.mean_m_s = Vec3(1.0, 2.0, 0.0);
  s.wind.gust_std_m_s = 0.0;
  s.wind.measurement_noise_m_s = 0.0;
  s.simulation.position_noise_m = 0.0;
  return s;
}

std::shared_ptr<const world::Terrain> flat() {
  return std::make_shared<world::PeakTerrain>(world::PeakTerrainConfig{});
}

TEST(TruthWorld, SteadyFlightDriftsWithTheWindAndReachesEveryTimeExactly) {
  mission::TruthWorld world(one_uav_scenario(), flat());
  world.advance_to(10.0037);  // not a multiple of the 5 ms step
  EXPECT_DOUBLE_EQ(world.time_s(), 10.0037);
  // Constant speed 10 m/s east plus wind (1, 2): exact for RK4 on constant velocity.
  EXPECT_NEAR(world.true_position(0).x(), 100 + 11.0 * 10.0037, 1e-9);
  EXPECT_NEAR(world.true_position(0).y(), 100 + 2.0 * 10.0037, 1e-9);
  EXPECT_NEAR((world.measured_wind(0) - Vec3(1, 2, 0)).norm(), 0.0, 1e-12);
}

// The anemometer's reading and the dynamics share one evaluation of the gusty wind per
// position and time: the reading must be the field's value where the UAV is now (after it
// moved, after its state was set elsewhere at the same time, while it holds its position as the
// time moves on), and reading it must not change the flight.
TEST(TruthWorld, WindReadingsFollowTheUavAndLeaveTheFlightUnchanged) {
  mission::Scenario s = one_uav_scenario();
  s.wind.gust_std_m_s = 3.0;
  mission::TruthWorld read(s, flat()), unread(s, flat());
  const auto truth_at_uav = [&] { return read.wind().at(read.true_position(0), read.time_s()); };
  for (int k = 1; k <= 50; ++k) {
    ASSERT_EQ(read.measured_wind(0), truth_at_uav()) << k;
    read.set_command(0, vehicle::Input(10.0 + 0.05 * k, 0.01 * k, 0.2));
    unread.set_command(0, vehicle::Input(10.0 + 0.05 * k, 0.01 * k, 0.2));
    read.advance_to(0.02 * k);
    unread.advance_to(0.02 * k);
    ASSERT_EQ(read.true_state(0), unread.true_state(0)) << k;  // bit for bit
  }
  const Vec3 before = read.measured_wind(0);
  vehicle::State moved = read.true_state(0);
  moved.x() += 150.0;  // same time, another place
  read.set_state(0, moved);
  EXPECT_EQ(read.measured_wind(0), truth_at_uav());
  EXPECT_NE(read.measured_wind(0), before);
  // Holding, the UAV stays where it is while the time moves on: the gusts change there.
  read.hold(0);
  const Vec3 held = read.measured_wind(0);
  read.advance_to(read.time_s() + 2.0);
  EXPECT_EQ(read.measured_wind(0), truth_at_uav());
  EXPECT_NE(read.measured_wind(0), held);
}

TEST(TruthWorld, TruthLagsAreTheControllersScaledForModelMismatch) {
  mission::Scenario s = one_uav_scenario();
  s.simulation.truth_time_constant_scale = 2.0;
  mission::TruthWorld world(s, flat());
  world.set_command(0, vehicle::Input(14.0, 0.0, 0.0));
  const double tau_truth = 2.0 * s.uavs[0].vehicle.tau_v_s;
  world.advance_to(tau_truth);
  // 63 % of the 4 m/s step at the truth's own time constant.
  EXPECT_NEAR(world.true_state(0)[vehicle::kV], 10.0 + 4.0 * (1 - std::exp(-1.0)), 1e-6);
}

TEST(TruthWorld, PositionNoiseHasTheConfiguredSpreadAndIsSeeded) {
  mission::Scenario s = one_uav_scenario();
  s.simulation.position_noise_m = 0.5;
  mission::TruthWorld a(s, flat()), b(s, flat());
  double sum2 = 0.0;
  constexpr int kN = 20000;
  for (int i = 0; i < kN; ++i) {
    const vehicle::State ma = a.measured_state(0), mb = b.measured_state(0);
    EXPECT_EQ(ma, mb);
    sum2 += (ma.head<3>() - a.true_position(0)).squaredNorm();
  }
  // E|n|² = 3σ²; relative standard error of the mean of 3N squared normals is √(2/(3N)).
  EXPECT_NEAR(std::sqrt(sum2 / (3 * kN)), 0.5, 0.5 * 5 * std::sqrt(2.0 / (3 * kN)));
}

TEST(TruthWorld, ThreatIsSensedWhileActiveAndInRange) {
  mission::Scenario s = one_uav_scenario();
  world::Threat t;
  t.centre_m = Vec3(300, 100, 100);
  t.radius_m = 20.0;
  t.appear_s = 1.0;
  t.vanish_s = 100.0;
  s.threats.push_back(t);
  mission::TruthWorld world(s, flat());
  std::vector<int> sensed;
  world.sensed_threats(0, sensed);
  EXPECT_TRUE(sensed.empty());  // not yet appeared, and 180 m from its surface
  world.advance_to(9.0);        // the UAV is 99 m further east: surface ~ 81 m away
  world.sensed_threats(0, sensed);
  ASSERT_EQ(sensed.size(), 1u);
  EXPECT_EQ(sensed[0], 0);
}

}  // namespace
}  // namespace ridgeline::mission
