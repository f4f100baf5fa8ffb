// px4_fleet.hpp and px4_vehicle.hpp: the companion's lock-step fleet on PX4's DDS topics against
// simulated vehicles served on those topics (each on a participant and thread of its own, as
// `vehicle-sim --px4-dds` processes are). A vehicle flown through the topics must end where a
// twin fed the same MAVLink setpoints directly ends (the topics add float32 rounding only).
// Odometry with NaN is rejected and counted; a vehicle on an unknown namespace, or one that
// never reports, is one error naming the UAV, the topic and what was waited for.
#include "px4/px4_fleet.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <limits>
#include <thread>

#include "core/error.hpp"
#include "mavlink/ned_frame.hpp"
#include "px4/px4_frame.hpp"
#include "px4/px4_vehicle.hpp"

namespace ridgeline::px4 {
namespace {

constexpr int kDomain = 213;  // a domain of these tests; partitions keep runs apart
constexpr double kPeriod = 0.02;

transport_dds::DdsOptions dds() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  transport_dds::DdsOptions o;
  o.domain_id = kDomain;
  o.partition =
      std::string("ridgeline-fleet-test-") + std::to_string(::getpid()) + "-" + info->name();
  return o;
}

mavlink::SimulatedVehicleOptions vehicle_options(const Vec3& start) {
  mavlink::SimulatedVehicleOptions o;
  o.initial_state.head<3>() = start;
  o.initial_state[vehicle::kPsi] = 0.3;
  o.offboard_entry_speed_m_s = 10.0;
  return o;
}

/// A simulated vehicle served on `ns` on a thread until destroyed.
struct ServedVehicle {
  ServedVehicle(const std::string& ns, const Vec3& start)
      : vehicle(vehicle_options(start)),
        link(std::make_shared<transport_dds::DdsParticipant>(dds()),
             transport_dds::Px4Side::kVehicle, {ns}),
        thread([this] { stats = serve_px4_vehicle_lockstep(vehicle, link, kPeriod, 0.0, stop); }) {}
  ~ServedVehicle() { finish(); }
  /// Stops serving; `stats` is final afterwards.
  void finish() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
  mavlink::SimulatedVehicle vehicle;
  transport_dds::Px4Link link;
  std::atomic<bool> stop{false};
  Px4VehicleStats stats;
  std::thread thread;
};

std::unique_ptr<Px4Fleet> fleet(const std::vector<std::string>& namespaces, double timeout_s) {
  Px4FleetOptions o;
  o.period_s = kPeriod;
  o.start_timeout_s = o.step_timeout_s = timeout_s;
  std::vector<std::string> names;
  for (std::size_t i = 0; i < namespaces.size(); ++i)
    names.push_back("uav" + std::to_string(i + 1) + " (UAV " + std::to_string(i) + ")");
  return std::make_unique<Px4Fleet>(o, names,
                                    std::make_unique<transport_dds::Px4Link>(
                                        std::make_shared<transport_dds::DdsParticipant>(dds()),
                                        transport_dds::Px4Side::kCompanion, namespaces));
}

TEST(Px4Fleet, VehiclesOnPx4TopicsFlyAsTheirTwinsFedMavlinkDirectly) {
  const Vec3 starts[] = {Vec3(100.0, 130.0, 60.0), Vec3(140.0, 100.0, 65.0)};
  ServedVehicle a("uav_1", starts[0]), b("uav_2", starts[1]);
  auto f = fleet({"uav_1", "uav_2"}, 10.0);
  std::vector<mavlink::FleetReport> reports;
  f->start(reports);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_NEAR((reports[1].position_m - starts[1]).norm(), 0.0, 1e-4);

  // The twins: the same vehicles, armed in offboard and stepped with the same setpoints.
  std::vector<mavlink::SimulatedVehicle> twins;
  for (const Vec3& s : starts) {
    twins.emplace_back(vehicle_options(s));
    mavlink::SimulatedVehicle& t = twins.back();
    t.handle_lockstep(
        mavlink::hold_setpoint(s, 0.0, mavlink::SimulatedVehicle::kKeepAliveStamp, 1, 1), kPeriod);
    t.handle_lockstep(command_long(arm_command(1, 0)), kPeriod);
    t.handle_lockstep(command_long(offboard_command(1, 0)), kPeriod);
    ASSERT_TRUE(t.armed() && t.offboard());
  }
  const std::vector<mavlink::FleetCommand> commands = {{vehicle::Input(11.0, 0.05, 1.0), false},
                                                       {vehicle::Input(9.0, -0.04, -0.5), false}};
  constexpr int kSteps = 200;
  for (int k = 0; k < kSteps; ++k) {
    for (std::size_t i = 0; i < 2; ++i) {
      const double heading =
          mavlink::ned_yaw_to_enu_heading(twins[i].lockstep_state_report().attitude.yaw);
      twins[i].handle_lockstep(mavlink::velocity_setpoint(
                                   commands[i].command, heading,
                                   mavlink::SimulatedVehicle::lockstep_stamp_ms(k, kPeriod), 1, 1),
                               kPeriod);
    }
    f->step(static_cast<std::uint64_t>(k), commands, reports);
  }
  for (std::size_t i = 0; i < 2; ++i) {
    // Positions are float32 on the wire (~1e-5 m at these coordinates), and the heading the
    // fleet sends back comes through a float32 quaternion instead of the yaw itself.
    EXPECT_NEAR((reports[i].position_m - twins[i].state().head<3>()).norm(), 0.0, 1e-3) << i;
    EXPECT_NEAR(reports[i].heading_rad, twins[i].state()[vehicle::kPsi], 1e-5) << i;
    EXPECT_EQ(f->stats(static_cast<int>(i)).steps, static_cast<std::uint64_t>(kSteps));
    EXPECT_EQ(f->stats(static_cast<int>(i)).rejected, 0u);
  }
  EXPECT_EQ(a.vehicle.stats().lockstep_steps, static_cast<std::uint64_t>(kSteps));
}

TEST(Px4Fleet, AVehicleOnAnUnknownNamespaceIsATimeoutNamingTheUavTopicAndWhatWasAwaited) {
  ServedVehicle stray("uav_9", Vec3(100.0, 130.0, 60.0));
  auto f = fleet({"uav_1"}, 1.0);
  std::vector<mavlink::FleetReport> reports;
  try {
    f->start(reports);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "uav1 (UAV 0): the PX4 vehicle did not start a lock-step offboard flight within "
              "1 s; waited for rt/uav_1/fmu/out/vehicle_odometry: no usable odometry (0 "
              "received, 0 rejected)");
  }
}

TEST(Px4Fleet, OdometryWithNaNIsRejectedAndCountedNeverFlownOn) {
  transport_dds::Px4Link fake(std::make_shared<transport_dds::DdsParticipant>(dds()),
                              transport_dds::Px4Side::kVehicle, {"uav_1"});
  std::atomic<bool> stop{false};
  std::thread publisher([&] {
    msg::VehicleOdometry o =
        odometry(mavlink::report_state(vehicle::State::Zero(), Vec3::Zero(), 0), 0);
    o.velocity[2] = std::numeric_limits<float>::quiet_NaN();
    while (!stop) {
      fake.publish(0, o);
      fake.publish(0, vehicle_status(true, true, 0));
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  auto f = fleet({"uav_1"}, 1.0);
  std::vector<mavlink::FleetReport> reports;
  std::string error;
  try {
    f->start(reports);
  } catch (const InputError& e) {
    error = e.what();
  }
  stop = true;
  publisher.join();
  EXPECT_GT(f->stats(0).rejected, 0u);
  EXPECT_EQ(f->stats(0).rejected, f->stats(0).odometry_received);
  EXPECT_EQ(f->stats(0).last_rejection, "rt/uav_1/fmu/out/vehicle_odometry: velocity[2] is nan");
  EXPECT_NE(error.find("waited for rt/uav_1/fmu/out/vehicle_odometry: no usable odometry"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("last: rt/uav_1/fmu/out/vehicle_odometry: velocity[2] is nan"),
            std::string::npos)
      << error;
}

// As PX4, the vehicle enters offboard only while offboard_control_mode arrives: setpoints and
// commands alone arm it but never switch it to offboard.
TEST(Px4Vehicle, OffboardIsRefusedWithoutTheOffboardControlModeStream) {
  ServedVehicle served("uav_1", Vec3(100.0, 130.0, 60.0));
  transport_dds::Px4Link companion(std::make_shared<transport_dds::DdsParticipant>(dds()),
                                   transport_dds::Px4Side::kCompanion, {"uav_1"});
  const mavlink::SetPositionTargetLocalNed hold = mavlink::hold_setpoint(
      Vec3(100.0, 130.0, 60.0), 0.0, mavlink::SimulatedVehicle::kKeepAliveStamp, 1, 1);
  bool armed = false, offboard = false;
  std::vector<transport_dds::Px4Received> got;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (std::chrono::steady_clock::now() < until) {
    companion.publish(0, trajectory_setpoint(hold, kKeepAliveStampUs));
    companion.publish(
        0, armed ? offboard_command(1, kKeepAliveStampUs) : arm_command(1, kKeepAliveStampUs));
    companion.wait(0.05);
    got.clear();
    companion.take(got);
    for (const transport_dds::Px4Received& r : got)
      if (const auto* s = std::get_if<msg::VehicleStatus>(&r.message)) {
        armed = armed || status_armed(*s);
        offboard = offboard || status_offboard(*s);
      }
  }
  served.finish();
  EXPECT_TRUE(armed);
  EXPECT_FALSE(offboard);
  EXPECT_GT(served.stats.commands_refused, 0u);
  EXPECT_EQ(served.stats.last_rejection,
            "rt/uav_1/fmu/in/vehicle_command: offboard refused: no offboard_control_mode within "
            "0.5 s");
}

}  // namespace
}  // namespace ridgeline::px4
