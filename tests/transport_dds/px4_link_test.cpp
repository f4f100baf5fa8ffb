// px4_link.hpp: PX4's topics between a companion's and a vehicle's participant on loopback.
// Samples arrive field by field on the namespace they were written to and on no other; bad
// namespaces are refused naming the option. (The wire format against another DDS
// implementation: tests/fastdds/.)
#include "transport_dds/px4_link.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "core/error.hpp"

namespace ridgeline::transport_dds {
namespace {

constexpr int kDomain = 212;  // a domain of these tests; partitions keep runs apart

std::shared_ptr<DdsParticipant> participant() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  DdsOptions o;
  o.domain_id = kDomain;
  o.partition =
      std::string("ridgeline-px4-test-") + std::to_string(::getpid()) + "-" + info->name();
  return std::make_shared<DdsParticipant>(o);
}

/// Publishes with `send` every 20 ms (best effort: samples before discovery are lost) and
/// takes from `link` until `done` or 10 s.
template <typename Send, typename Done>
bool exchange(Px4Link& link, std::vector<Px4Received>& got, Send&& send, Done&& done) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < until) {
    send();
    link.wait(0.02);
    link.take(got);
    if (done()) return true;
  }
  return false;
}

TEST(Px4Link, TopicNamesFollowPx4sNamespaces) {
  EXPECT_EQ(px4_topic_name("rt/fmu/in/trajectory_setpoint", ""), "rt/fmu/in/trajectory_setpoint");
  EXPECT_EQ(px4_topic_name("rt/fmu/out/vehicle_odometry", "uav_2"),
            "rt/uav_2/fmu/out/vehicle_odometry");
  for (const char* good : {"", "uav_0", "uav_1", "uav_12"})
    EXPECT_FALSE(check_px4_namespace(good)) << good;
  for (const char* bad : {"uav", "uav_", "uav_01", "uav_x", "fmu", "/uav_1", "uav_1/", "uav_1000"})
    EXPECT_TRUE(check_px4_namespace(bad)) << bad;
}

TEST(Px4Link, ASetpointAndOdometryCrossFieldByFieldOnTheirNamespaceOnly) {
  Px4Link companion(participant(), Px4Side::kCompanion, {"uav_1", "uav_2"});
  Px4Link vehicle(participant(), Px4Side::kVehicle, {"uav_2"});

  px4::TrajectorySetpoint sp;
  sp.timestamp = 123456789012345ull;
  sp.position = {1.5f, -2.25f, 3.125f};
  sp.velocity = {4.5f, 5.75f, -6.0f};
  sp.acceleration = {0.5f, 0.25f, 0.125f};
  sp.jerk = {-1.0f, -2.0f, -3.0f};
  sp.yaw = 0.75f;
  sp.yawspeed = -0.125f;
  px4::TrajectorySetpoint other = sp;
  other.yaw = -3.0f;  // for uav_1: must never reach uav_2's vehicle
  std::vector<Px4Received> got;
  ASSERT_TRUE(exchange(
      vehicle, got,
      [&] {
        companion.publish(0, other);
        companion.publish(1, sp);
      },
      [&] { return !got.empty(); }));
  for (const Px4Received& r : got) {
    EXPECT_EQ(r.vehicle, 0);
    const auto* t = std::get_if<px4::TrajectorySetpoint>(&r.message);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(t->timestamp, sp.timestamp);
    EXPECT_EQ(t->position, sp.position);
    EXPECT_EQ(t->velocity, sp.velocity);
    EXPECT_EQ(t->acceleration, sp.acceleration);
    EXPECT_EQ(t->jerk, sp.jerk);
    EXPECT_EQ(t->yaw, sp.yaw);
    EXPECT_EQ(t->yawspeed, sp.yawspeed);
  }

  px4::VehicleOdometry o;
  o.timestamp = 20000;
  o.timestamp_sample = 19000;
  o.pose_frame = 1;
  o.position = {10.0f, 20.0f, -30.0f};
  o.q = {0.5f, 0.5f, -0.5f, 0.5f};
  o.velocity_frame = 1;
  o.velocity = {1.0f, 2.0f, 3.0f};
  o.angular_velocity = {0.1f, 0.2f, 0.3f};
  o.position_variance = {0.01f, 0.02f, 0.03f};
  o.orientation_variance = {0.04f, 0.05f, 0.06f};
  o.velocity_variance = {0.07f, 0.08f, 0.09f};
  o.reset_counter = 7;
  o.quality = -3;
  px4::VehicleStatus s;
  s.arming_state = 2;
  s.nav_state = 14;
  s.failure_detector_status = 0x8001;
  s.pre_flight_checks_pass = true;
  got.clear();
  bool have_odometry = false, have_status = false;
  ASSERT_TRUE(exchange(
      companion, got,
      [&] {
        vehicle.publish(0, o);
        vehicle.publish(0, s);
      },
      [&] {
        for (const Px4Received& r : got) {
          EXPECT_EQ(r.vehicle, 1);  // uav_2 is the companion's vehicle 1
          if (const auto* x = std::get_if<px4::VehicleOdometry>(&r.message)) {
            have_odometry = true;
            EXPECT_EQ(x->timestamp, o.timestamp);
            EXPECT_EQ(x->timestamp_sample, o.timestamp_sample);
            EXPECT_EQ(x->pose_frame, o.pose_frame);
            EXPECT_EQ(x->position, o.position);
            EXPECT_EQ(x->q, o.q);
            EXPECT_EQ(x->velocity_frame, o.velocity_frame);
            EXPECT_EQ(x->velocity, o.velocity);
            EXPECT_EQ(x->angular_velocity, o.angular_velocity);
            EXPECT_EQ(x->position_variance, o.position_variance);
            EXPECT_EQ(x->orientation_variance, o.orientation_variance);
            EXPECT_EQ(x->velocity_variance, o.velocity_variance);
            EXPECT_EQ(x->reset_counter, o.reset_counter);
            EXPECT_EQ(x->quality, o.quality);
          } else if (const auto* y = std::get_if<px4::VehicleStatus>(&r.message)) {
            have_status = true;
            EXPECT_EQ(y->arming_state, 2);
            EXPECT_EQ(y->nav_state, 14);
            EXPECT_EQ(y->failure_detector_status, 0x8001);
            EXPECT_TRUE(y->pre_flight_checks_pass);
          }
        }
        got.clear();
        return have_odometry && have_status;
      }));
}

TEST(Px4Link, BadNamespacesAndWrongSidesAreRefused) {
  auto p = participant();
  EXPECT_THROW(Px4Link(p, Px4Side::kCompanion, {"uav_1", "uav_x"}), InputError);
  try {
    Px4Link link(p, Px4Side::kCompanion, {"uav_1", "uav_1"});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "namespaces: 'uav_1' is given twice");
  }
  EXPECT_THROW(Px4Link(p, Px4Side::kCompanion, {"", "uav_1"}), InputError);
  EXPECT_THROW(Px4Link(p, Px4Side::kCompanion, {}), InputError);
  Px4Link companion(p, Px4Side::kCompanion, {"uav_1"});
  EXPECT_THROW(companion.publish(0, px4::VehicleOdometry{}), InputError);
  EXPECT_THROW(companion.publish(1, px4::TrajectorySetpoint{}), InputError);
}

}  // namespace
}  // namespace ridgeline::transport_dds
