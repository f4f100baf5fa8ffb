// px4_frame.hpp: px4_msgs ↔ the MAVLink path's messages. Round trips must be exact up to
// float32 (the wire's type on both paths); a setpoint or odometry that cannot be flown on is
// refused with the field named.
#include "px4/px4_frame.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "mavlink/ned_frame.hpp"

namespace {

using namespace ridgeline;
using px4::msg::TrajectorySetpoint;
using px4::msg::VehicleOdometry;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(Px4Frame, AVelocitySetpointRoundTripsThroughATrajectorySetpoint) {
  const vehicle::Input u(11.0, -0.07, 1.5);
  const mavlink::SetPositionTargetLocalNed sp = mavlink::velocity_setpoint(u, 0.6, 4020, 1, 1);
  const TrajectorySetpoint t = px4::trajectory_setpoint(sp, px4::stamp_us(4020));
  EXPECT_EQ(t.timestamp, 4020000u);
  EXPECT_TRUE(std::isnan(t.position[0]) && std::isnan(t.yaw) && std::isnan(t.acceleration[2]));
  EXPECT_EQ(t.velocity[0], sp.vx);
  EXPECT_EQ(t.yawspeed, sp.yaw_rate);
  const px4::SetpointFromPx4 back = px4::setpoint_from_px4(t);
  ASSERT_TRUE(back.setpoint) << back.error;
  EXPECT_EQ(*back.setpoint, sp);
  // The command the vehicle flies is the one sent (float32 on both wires).
  const mavlink::SetpointCommand c = mavlink::command_from_setpoint(*back.setpoint);
  ASSERT_TRUE(c.command) << c.error;
  EXPECT_NEAR((*c.command - u).norm(), 0.0, 1e-5);
}

TEST(Px4Frame, AHoldAndTheKeepAliveStampRoundTrip) {
  const mavlink::SetPositionTargetLocalNed hold = mavlink::hold_setpoint(
      Vec3(100.0, 130.0, 60.0), 0.0, mavlink::SimulatedVehicle::kKeepAliveStamp, 1, 1);
  const TrajectorySetpoint t = px4::trajectory_setpoint(hold, px4::kKeepAliveStampUs);
  EXPECT_TRUE(std::isnan(t.velocity[1]) && std::isnan(t.yawspeed));
  const px4::SetpointFromPx4 back = px4::setpoint_from_px4(t);
  ASSERT_TRUE(back.setpoint) << back.error;
  EXPECT_EQ(*back.setpoint, hold);
  EXPECT_EQ(back.setpoint->time_boot_ms, mavlink::SimulatedVehicle::kKeepAliveStamp);
}

TEST(Px4Frame, ASetpointWithNaNWhereItMattersIsRefusedNamingTheField) {
  TrajectorySetpoint t = px4::trajectory_setpoint(
      mavlink::velocity_setpoint(vehicle::Input(10, 0, 0), 0.0, 0, 1, 1), 0);
  t.velocity[1] = kNaN;
  EXPECT_EQ(px4::setpoint_from_px4(t).error,
            "velocity[1] is nan in a velocity setpoint (NaN position)");
  t.velocity[1] = 0.0f;
  t.yawspeed = std::numeric_limits<float>::infinity();
  EXPECT_EQ(px4::setpoint_from_px4(t).error,
            "yawspeed is inf in a velocity setpoint (NaN position)");
  t.yawspeed = 0.0f;
  t.position = {1.0f, 2.0f, kNaN};
  EXPECT_NE(px4::setpoint_from_px4(t).error.find("position and velocity both set"),
            std::string::npos);
  t.velocity = {kNaN, kNaN, kNaN};
  EXPECT_EQ(px4::setpoint_from_px4(t).error, "position[2] is nan in a hold (NaN velocity)");
  EXPECT_FALSE(px4::setpoint_from_px4(t).setpoint);
}

// The odometry carries the attitude as a quaternion and body rates: heading and turn rate come
// back to float32 precision also when climbing (pitch ≠ 0, where body r ≠ yaw rate).
TEST(Px4Frame, OdometryGivesBackPositionVelocityHeadingAndTurnRate) {
  vehicle::State s = vehicle::State::Zero();
  s << 250.0, 900.0, 140.0, 2.5, 12.0, 0.08, 2.0;  // x, y, z, ψ, v, ω, w
  const Vec3 wind(1.5, -0.5, 0.2);
  const double home_m = 30.0;
  const mavlink::StateReport r = mavlink::report_state(s, wind, 7000, home_m);
  const VehicleOdometry o = px4::odometry(r, px4::stamp_us(7000));
  EXPECT_EQ(o.timestamp, 7000000u);
  EXPECT_EQ(o.pose_frame, VehicleOdometry::kPoseFrameNed);
  const px4::ReportFromPx4 back = px4::report_from_px4(o, home_m);
  ASSERT_TRUE(back.report) << back.error;
  EXPECT_NEAR((back.report->position_m - Vec3(250.0, 900.0, 140.0)).norm(), 0.0, 1e-4);
  const Vec3 ground(12.0 * std::cos(2.5) + 1.5, 12.0 * std::sin(2.5) - 0.5, 2.2);
  EXPECT_NEAR((back.report->ground_velocity_m_s - ground).norm(), 0.0, 1e-5);
  EXPECT_NEAR(back.report->heading_rad, 2.5, 1e-6);
  EXPECT_NEAR(back.report->turn_rate_rad_s, 0.08, 1e-6);
}

// The real-time companion reads odometry as the MAVLink path's LOCAL_POSITION_NED + ATTITUDE:
// the model state comes back as from the MAVLink reports themselves, to float32 precision.
TEST(Px4Frame, OdometryGivesBackTheMavlinkReportsTheCompanionReads) {
  vehicle::State s = vehicle::State::Zero();
  s << 250.0, 900.0, 140.0, -2.0, 12.0, -0.05, 1.5;  // x, y, z, ψ, v, ω, w
  const double home_m = 30.0;
  const mavlink::StateReport r = mavlink::report_state(s, Vec3::Zero(), 7000, home_m);
  const px4::StateFromPx4 back = px4::state_report_from_px4(px4::odometry(r, 123), 4321);
  ASSERT_TRUE(back.report) << back.error;
  EXPECT_EQ(back.report->position.time_boot_ms, 4321u);
  EXPECT_EQ(back.report->attitude.time_boot_ms, 4321u);
  const vehicle::State direct = mavlink::state_from_report(r.position, r.attitude, home_m);
  const vehicle::State via_px4 =
      mavlink::state_from_report(back.report->position, back.report->attitude, home_m);
  EXPECT_LT((direct - via_px4).cwiseAbs().maxCoeff(), 1e-5) << (direct - via_px4).transpose();
  EXPECT_LT((via_px4 - s).cwiseAbs().maxCoeff(), 1e-4) << (via_px4 - s).transpose();
  VehicleOdometry bad = px4::odometry(r, 0);
  bad.angular_velocity[2] = kNaN;
  EXPECT_EQ(px4::state_report_from_px4(bad, 0).error, "angular_velocity[2] is nan");
  EXPECT_FALSE(px4::state_report_from_px4(bad, 0).report);
}

TEST(Px4Frame, OdometryWithNaNOrAnotherFrameIsRefusedNamingTheField) {
  const mavlink::StateReport r = mavlink::report_state(vehicle::State::Zero(), Vec3::Zero(), 0);
  VehicleOdometry o = px4::odometry(r, 0);
  o.position[0] = kNaN;
  EXPECT_EQ(px4::report_from_px4(o, 0.0).error, "position[0] is nan");
  o = px4::odometry(r, 0);
  o.q[3] = kNaN;
  EXPECT_EQ(px4::report_from_px4(o, 0.0).error, "q[3] is nan");
  o = px4::odometry(r, 0);
  o.q = {0.5f, 0.0f, 0.0f, 0.0f};
  EXPECT_EQ(px4::report_from_px4(o, 0.0).error, "q has norm 0.500000, not a rotation");
  o = px4::odometry(r, 0);
  o.pose_frame = 2;  // FRD
  EXPECT_EQ(px4::report_from_px4(o, 0.0).error, "pose_frame 2 is not NED (1)");
  EXPECT_FALSE(px4::report_from_px4(o, 0.0).report);
}

TEST(Px4Frame, CommandsAndStatusCarryPx4sNumbers) {
  const auto arm = px4::arm_command(1, 0);
  EXPECT_EQ(arm.command, 400u);
  EXPECT_EQ(arm.param1, 1.0f);
  const auto offboard = px4::offboard_command(1, 0);
  EXPECT_EQ(offboard.command, 176u);
  EXPECT_EQ(offboard.param1, 1.0f);
  EXPECT_EQ(offboard.param2, 6.0f);
  const mavlink::CommandLong l = px4::command_long(offboard);
  EXPECT_EQ(l.command, mavlink::kMavCmdDoSetMode);
  EXPECT_EQ(l.param2, 6.0f);
  const auto status = px4::vehicle_status(true, true, 20000);
  EXPECT_EQ(status.arming_state, 2);
  EXPECT_EQ(status.nav_state, 14);
  EXPECT_TRUE(px4::status_armed(status) && px4::status_offboard(status));
  EXPECT_FALSE(px4::status_offboard(px4::vehicle_status(true, false, 0)));
  // The status as the MAVLink pilot reads it, and the pilot's commands as PX4 reads them.
  const mavlink::Heartbeat h = px4::heartbeat_from_px4(status);
  EXPECT_EQ(h.base_mode, mavlink::kModeFlagSafetyArmed | mavlink::kModeFlagCustomModeEnabled);
  EXPECT_EQ(h.custom_mode, mavlink::kPx4CustomModeOffboard);
  const mavlink::Heartbeat standby = px4::heartbeat_from_px4(px4::vehicle_status(false, false, 0));
  EXPECT_EQ(standby.base_mode & mavlink::kModeFlagSafetyArmed, 0);
  EXPECT_EQ(standby.custom_mode, 0u);
  const auto again = px4::vehicle_command(l, 555);
  EXPECT_EQ(again.timestamp, 555u);
  EXPECT_EQ(again.command, offboard.command);
  EXPECT_EQ(again.param1, offboard.param1);
  EXPECT_EQ(again.param2, offboard.param2);
  EXPECT_EQ(again.target_system, offboard.target_system);
  EXPECT_EQ(again.target_component, offboard.target_component);
  EXPECT_EQ(again.source_component, 191);
  EXPECT_TRUE(again.from_external);
}

}  // namespace
