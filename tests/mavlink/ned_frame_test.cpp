// ENU ↔ NED (src/mavlink/ned_frame.*): the axes, the yaw convention, and the state and
// command round trips through the messages.
#include "mavlink/ned_frame.hpp"

#include <gtest/gtest.h>

#include <random>

namespace ridgeline::mavlink {
namespace {

TEST(NedFrame, NorthIsEnuYEastIsEnuXDownIsMinusUp) {
  const Vec3 ned = enu_to_ned(Vec3(1.0, 2.0, 3.0));  // 1 m east, 2 m north, 3 m up
  EXPECT_EQ(ned, Vec3(2.0, 1.0, -3.0));
  EXPECT_EQ(ned_to_enu(ned), Vec3(1.0, 2.0, 3.0));
}

TEST(NedFrame, YawIsMeasuredFromNorthClockwise) {
  // Heading east (ψ = 0) is yaw 90°; north (ψ = 90°) is yaw 0; south is 180°; west is −90°.
  EXPECT_NEAR(enu_heading_to_ned_yaw(0.0), 0.5 * kPi, 1e-15);
  EXPECT_NEAR(enu_heading_to_ned_yaw(0.5 * kPi), 0.0, 1e-15);
  EXPECT_NEAR(enu_heading_to_ned_yaw(-0.5 * kPi), kPi, 1e-15);  // π, not −π: (−π, π]
  EXPECT_NEAR(enu_heading_to_ned_yaw(kPi), -0.5 * kPi, 1e-15);
  EXPECT_NEAR(enu_heading_to_ned_yaw(2.5 * kPi), 0.0, 1e-12);   // wrapped
  EXPECT_NEAR(ned_yaw_to_enu_heading(-0.5 * kPi), kPi, 1e-15);  // yaw west → ψ = π
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> angle(-10.0, 10.0);
  for (int i = 0; i < 1000; ++i) {
    const double psi = angle(rng);
    EXPECT_NEAR(wrap_angle(ned_yaw_to_enu_heading(enu_heading_to_ned_yaw(psi)) - psi), 0.0, 1e-12);
  }
}

// A vehicle flying north-east, climbing and turning left (counter-clockwise seen from above):
// NED velocity north and east positive, vz negative, yaw speed negative.
TEST(NedFrame, StateReportCarriesTheStateAndReadsBack) {
  vehicle::State s;
  s << 100.0, 200.0, 300.0, kPi / 4, 10.0, 0.2, 1.5;
  const StateReport r = report_state(s, Vec3::Zero(), 1234);
  EXPECT_EQ(r.position.time_boot_ms, 1234u);
  EXPECT_FLOAT_EQ(r.position.x, 200.0f);
  EXPECT_FLOAT_EQ(r.position.y, 100.0f);
  EXPECT_FLOAT_EQ(r.position.z, -300.0f);
  EXPECT_NEAR(r.position.vx, 10.0 / std::sqrt(2.0), 1e-5);
  EXPECT_NEAR(r.position.vy, 10.0 / std::sqrt(2.0), 1e-5);
  EXPECT_FLOAT_EQ(r.position.vz, -1.5f);
  EXPECT_NEAR(r.attitude.yaw, kPi / 4, 1e-6);
  EXPECT_FLOAT_EQ(r.attitude.yawspeed, -0.2f);
  EXPECT_NEAR(r.attitude.pitch, std::atan2(1.5, 10.0), 1e-6);
  const vehicle::State back = state_from_report(r.position, r.attitude);
  // float on the wire: 300 m carries ~3e-5 m of rounding.
  EXPECT_LT((back - s).cwiseAbs().maxCoeff(), 1e-4) << back.transpose();
}

// With a geodetic origin our z is above mean sea level while PX4's local NED z is measured
// from home: a UAV 150 m above a home at 800 m AMSL reports NED z = −150, not −950.
TEST(NedFrame, HomeAltitudeIsTheOneOffsetBetweenOurZAndPx4LocalNedZ) {
  EXPECT_EQ(enu_position_to_ned(Vec3(10.0, 20.0, 950.0), 800.0), Vec3(20.0, 10.0, -150.0));
  EXPECT_EQ(ned_position_to_enu(Vec3(20.0, 10.0, -150.0), 800.0), Vec3(10.0, 20.0, 950.0));
  // Home 0 is the plain axis swap.
  EXPECT_EQ(enu_position_to_ned(Vec3(1.0, 2.0, 3.0), 0.0), enu_to_ned(Vec3(1.0, 2.0, 3.0)));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> coord(-5000.0, 5000.0), home(-400.0, 4000.0);
  for (int i = 0; i < 1000; ++i) {
    const Vec3 p(coord(rng), coord(rng), coord(rng));
    const double h = home(rng);
    EXPECT_LT((ned_position_to_enu(enu_position_to_ned(p, h), h) - p).norm(), 1e-9);
    EXPECT_NEAR(enu_position_to_ned(p, h).z(), h - p.z(), 1e-9);  // z_ned = −(z − h_home)
  }
  // Through the messages: the state report and a hold setpoint carry the offset both ways.
  vehicle::State s;
  s << 100.0, 200.0, 950.0, 0.3, 10.0, 0.0, 0.0;
  const StateReport r = report_state(s, Vec3::Zero(), 0, 800.0);
  EXPECT_FLOAT_EQ(r.position.z, -150.0f);
  EXPECT_NEAR(state_from_report(r.position, r.attitude, 800.0)[vehicle::kZ], 950.0, 1e-4);
  EXPECT_NEAR(state_from_report(r.position, r.attitude)[vehicle::kZ], 150.0, 1e-4);  // home 0
  const SetPositionTargetLocalNed hold = hold_setpoint(Vec3(100.0, 200.0, 950.0), 800.0, 5, 1, 1);
  EXPECT_EQ(hold.type_mask, kTypeMaskPositionHold);
  EXPECT_FLOAT_EQ(hold.z, -150.0f);
  const SetpointCommand c = command_from_setpoint(hold, 800.0);
  ASSERT_TRUE(c.hold_position_enu_m.has_value()) << c.error;
  EXPECT_FALSE(c.command.has_value());
  EXPECT_LT((*c.hold_position_enu_m - Vec3(100.0, 200.0, 950.0)).norm(), 1e-4);
}

TEST(NedFrame, VelocitySetpointCarriesTheCommandAndReadsBack) {
  const vehicle::Input u(12.0, -0.3, 2.0);  // 12 m/s, turning right, climbing
  const double psi = deg_to_rad(200.0);
  const SetPositionTargetLocalNed sp = velocity_setpoint(u, psi, 7, 1, 1);
  EXPECT_EQ(sp.type_mask, 0b0101'1100'0111);  // position, acceleration and yaw ignored
  EXPECT_EQ(sp.coordinate_frame, kMavFrameLocalNed);
  EXPECT_NEAR(sp.vx, 12.0 * std::sin(psi), 1e-5);  // north
  EXPECT_NEAR(sp.vy, 12.0 * std::cos(psi), 1e-5);  // east
  EXPECT_FLOAT_EQ(sp.vz, -2.0f);
  EXPECT_FLOAT_EQ(sp.yaw_rate, 0.3f);
  const SetpointCommand c = command_from_setpoint(sp);
  ASSERT_TRUE(c.command.has_value()) << c.error;
  EXPECT_LT((*c.command - u).cwiseAbs().maxCoeff(), 1e-5);
}

TEST(NedFrame, SetpointsThisVehicleCannotFlyAreRefusedNamingTheField) {
  const SetPositionTargetLocalNed good = velocity_setpoint(vehicle::Input(10, 0, 0), 0.0, 0, 1, 1);
  auto error_of = [](SetPositionTargetLocalNed sp) { return command_from_setpoint(sp).error; };
  SetPositionTargetLocalNed sp = good;
  sp.coordinate_frame = 8;  // MAV_FRAME_BODY_NED
  EXPECT_EQ(error_of(sp).rfind("coordinate_frame: 8 is not MAV_FRAME_LOCAL_NED", 0), 0u) << error_of(sp);
  sp = good;
  sp.type_mask = static_cast<std::uint16_t>(sp.type_mask & ~kIgnoreX);  // a position setpoint
  EXPECT_EQ(error_of(sp).rfind("type_mask:", 0), 0u);
  EXPECT_NE(error_of(sp).find("position or acceleration"), std::string::npos);
  sp = good;
  sp.type_mask = static_cast<std::uint16_t>(sp.type_mask | kIgnoreVz);
  EXPECT_NE(error_of(sp).find("ignores part of the velocity"), std::string::npos);
  sp = good;
  sp.type_mask = static_cast<std::uint16_t>(sp.type_mask | kIgnoreYawRate);
  EXPECT_NE(error_of(sp).find("ignores the yaw rate"), std::string::npos);
  sp = good;
  sp.vy = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(error_of(sp).rfind("vy: ", 0), 0u);
  EXPECT_NE(error_of(sp).find("not finite"), std::string::npos);
}

}  // namespace
}  // namespace ridgeline::mavlink
