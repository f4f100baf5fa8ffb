// px4_pilot.hpp and the real-time px4_vehicle.hpp: the offboard companion (OffboardPilot) flown
// over PX4's DDS topics in real time against a simulated vehicle served on them on its own
// participant and thread (as `ridgeline fly --px4-dds` flies `vehicle-sim --px4-dds`). The
// pilot arms it, switches it to offboard and tracks a circle; odometry with NaN, a vehicle on
// another namespace and a setpoint with NaN are rejected and counted, or one error naming the
// UAV, the topic and what was waited for. Real time: these tests take seconds of wall time.
#include "px4/px4_pilot.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <limits>
#include <thread>

#include "core/error.hpp"
#include "mavlink/ned_frame.hpp"
#include "mpc/reference.hpp"
#include "px4/px4_frame.hpp"
#include "px4/px4_vehicle.hpp"

namespace ridgeline::px4 {
namespace {

constexpr int kDomain = 214;  // a domain of these tests; partitions keep runs apart
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

transport_dds::DdsOptions dds() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  transport_dds::DdsOptions o;
  o.domain_id = kDomain;
  o.partition =
      std::string("ridgeline-pilot-test-") + std::to_string(::getpid()) + "-" + info->name();
  return o;
}

transport_dds::Px4Link link(transport_dds::Px4Side side, const std::string& ns) {
  return transport_dds::Px4Link(std::make_shared<transport_dds::DdsParticipant>(dds()), side, {ns});
}

/// A real-time simulated vehicle on `ns`, hovering at (0, 0, 100) heading east, served on a
/// thread until finished.
struct ServedVehicle {
  explicit ServedVehicle(const std::string& ns)
      : vehicle(options()),
        served(link(transport_dds::Px4Side::kVehicle, ns)),
        thread([this] { stats = serve_px4_vehicle(vehicle, served, 0.0, stop); }) {}
  ~ServedVehicle() { finish(); }
  void finish() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
  static mavlink::SimulatedVehicleOptions options() {
    mavlink::SimulatedVehicleOptions o;
    o.initial_state[vehicle::kZ] = 100.0;
    // Lags 20 % slower than the tracker's model, as the mission's truth has them.
    o.params.tau_v_s *= 1.2;
    o.params.tau_omega_s *= 1.2;
    o.params.tau_w_s *= 1.2;
    return o;
  }
  mavlink::SimulatedVehicle vehicle;
  transport_dds::Px4Link served;
  std::atomic<bool> stop{false};
  Px4VehicleStats stats;
  std::thread thread;
};

std::shared_ptr<const mpc::ReferenceTrajectory> left_circle() {
  // Starts at the vehicle (0, 0, 100) heading east and turns left on a 150 m circle at 10 m/s.
  return std::make_shared<mpc::HelixReference>(
      mpc::HelixReference::Config{.centre_m = Vec3(0.0, 150.0, 100.0),
                                  .radius_m = 150.0,
                                  .speed_m_s = 10.0,
                                  .climb_rate_m_s = 0.0,
                                  .phase0_rad = -0.5 * kPi,
                                  .turn_left = true,
                                  .t0_s = 0.0});
}

mavlink::OffboardPilot pilot(double duration_s) {
  mavlink::OffboardPilotOptions o;
  o.flight_duration_s = duration_s;
  return mavlink::OffboardPilot(o, world::SafetyLimits{}, left_circle(), nullptr);
}

/// fly_px4_pilot's error, or "" when it flew.
std::string fly_error(mavlink::OffboardPilot& p, transport_dds::Px4Link& l, double timeout_s) {
  const std::atomic<bool> never{false};
  try {
    fly_px4_pilot(p, l, "uav1 (UAV 0)", 0.02, timeout_s, never);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Px4Pilot, ArmsStartsOffboardAndTracksACircleThroughARealTimeVehicleOnPx4Topics) {
  ServedVehicle v("uav_1");
  auto companion = link(transport_dds::Px4Side::kCompanion, "uav_1");
  mavlink::OffboardPilot p = pilot(4.0);
  const std::atomic<bool> never{false};
  const Px4PilotReport r = fly_px4_pilot(p, companion, "uav1 (UAV 0)", 0.02, 20.0, never);
  v.finish();
  const mavlink::FlightSummary s = p.summary();
  EXPECT_EQ(s.phase, mavlink::PilotPhase::kFinished);
  EXPECT_NEAR(s.flown_time_s, 4.0, 0.1);
  // 50 Hz for 4 s, less what a loaded machine loses to scheduling.
  EXPECT_GT(s.steps, 100);
  EXPECT_LT(s.stale_steps, 10);
  // The vehicle starts hovering while the reference moves at 10 m/s: it falls about v·τ_v
  // behind before the tracker catches up (the lock-step MAVLink test: 3.9 m at most).
  EXPECT_LT(s.tracking_max_m, 10.0);
  EXPECT_GT(s.path_length_m, 0.7 * 10.0 * 4.0);
  EXPECT_EQ(r.odometry_rejected, 0u);
  EXPECT_GT(r.odometry_received, 100u);
  EXPECT_GT(r.status_received, 0u);
  // The vehicle saw the offboard stream from the first period on, and refused nothing.
  EXPECT_EQ(v.stats.setpoints_rejected, 0u);
  EXPECT_EQ(v.stats.commands_refused, 0u);
  EXPECT_EQ(v.vehicle.stats().commands_refused, 0u) << v.vehicle.stats().last_error;
  EXPECT_GE(v.stats.offboard_control_modes, v.stats.setpoints);
  EXPECT_GT(v.stats.setpoints, 100u);
  EXPECT_GE(v.stats.commands, 2u);                  // arm, offboard
  EXPECT_GT(v.vehicle.state()[vehicle::kX], 20.0);  // it flew east along the circle's start
}

TEST(Px4Pilot, OdometryWithNaNIsRejectedAndCountedAndTheStartFailsNamingTheTopic) {
  auto fake = link(transport_dds::Px4Side::kVehicle, "uav_1");
  std::atomic<bool> stop{false};
  std::thread publisher([&] {
    msg::VehicleOdometry o =
        odometry(mavlink::report_state(vehicle::State::Zero(), Vec3::Zero(), 0), 0);
    o.velocity[2] = kNaN;
    while (!stop) {
      fake.publish(0, o);
      fake.publish(0, vehicle_status(true, true, 0));
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  auto companion = link(transport_dds::Px4Side::kCompanion, "uav_1");
  mavlink::OffboardPilot p = pilot(4.0);
  const std::string error = fly_error(p, companion, 1.5);
  stop = true;
  publisher.join();
  EXPECT_NE(error.find("uav1 (UAV 0): the PX4 vehicle did not start an offboard flight within "
                       "1.5 s (stuck waiting for the vehicle's state); waited for "
                       "rt/uav_1/fmu/out/vehicle_odometry: no usable odometry ("),
            std::string::npos)
      << error;
  EXPECT_NE(error.find(" rejected; last: rt/uav_1/fmu/out/vehicle_odometry: velocity[2] is nan)"),
            std::string::npos)
      << error;
  EXPECT_TRUE(p.log().empty());  // never flown on
}

TEST(Px4Pilot, AVehicleOnAnotherNamespaceIsOneErrorNamingTheUavTheTopicAndWhatWasAwaited) {
  ServedVehicle stray("uav_2");
  auto companion = link(transport_dds::Px4Side::kCompanion, "uav_1");
  mavlink::OffboardPilot p = pilot(4.0);
  EXPECT_EQ(fly_error(p, companion, 1.0),
            "uav1 (UAV 0): the PX4 vehicle did not start an offboard flight within 1 s (stuck "
            "waiting for the vehicle's state); waited for rt/uav_1/fmu/out/vehicle_odometry: no "
            "usable odometry (0 received, 0 rejected)");
  stray.finish();
  EXPECT_EQ(stray.stats.setpoints + stray.stats.offboard_control_modes, 0u);
}

TEST(Px4Pilot, AVehicleThatStopsReportingInFlightEndsTheFlightWithOneErrorNamingTheTopic) {
  ServedVehicle v("uav_1");
  auto companion = link(transport_dds::Px4Side::kCompanion, "uav_1");
  mavlink::OffboardPilot p = pilot(30.0);
  std::thread silence([&] {
    // The vehicle goes quiet 3 s in (its start takes well under a second).
    std::this_thread::sleep_for(std::chrono::seconds(3));
    v.stop = true;
  });
  const std::string error = fly_error(p, companion, 20.0);
  silence.join();
  v.finish();
  EXPECT_NE(error.find("uav1 (UAV 0): rt/uav_1/fmu/out/vehicle_odometry: no usable odometry for "),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("s in flight"), std::string::npos) << error;
  EXPECT_NE(error.find("the vehicle stopped reporting"), std::string::npos) << error;
  ASSERT_FALSE(p.log().empty());  // it was flying
  EXPECT_LT(p.log().back().t_s, 10.0);
}

// A setpoint with NaN velocity is rejected and counted by the real-time vehicle, never flown:
// with only such setpoints streaming, the vehicle arms but refuses offboard (no setpoint it can
// fly), though offboard_control_mode arrives.
TEST(Px4Vehicle, ARealTimeVehicleRejectsAndCountsSetpointsWithNaNAndNeverFliesThem) {
  ServedVehicle v("uav_1");
  auto companion = link(transport_dds::Px4Side::kCompanion, "uav_1");
  mavlink::SetPositionTargetLocalNed sp =
      mavlink::velocity_setpoint(vehicle::Input(10.0, 0.0, 0.0), 0.0, 0, 1, 1);
  sp.vy = kNaN;
  bool armed = false;
  std::vector<transport_dds::Px4Received> got;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (std::chrono::steady_clock::now() < until) {
    const std::uint64_t stamp = system_clock_us();
    companion.publish(0, offboard_control_mode(false, stamp));
    companion.publish(0, trajectory_setpoint(sp, stamp));
    companion.publish(0, armed ? offboard_command(1, stamp) : arm_command(1, stamp));
    companion.wait(0.05);
    got.clear();
    companion.take(got);
    for (const transport_dds::Px4Received& r : got)
      if (const auto* s = std::get_if<msg::VehicleStatus>(&r.message))
        armed = armed || status_armed(*s);
  }
  v.finish();
  EXPECT_TRUE(armed);
  EXPECT_FALSE(v.vehicle.offboard());
  EXPECT_GT(v.stats.setpoints_rejected, 0u);
  EXPECT_EQ(v.stats.setpoints_rejected, v.stats.setpoints);
  EXPECT_EQ(v.stats.last_rejection,
            "rt/uav_1/fmu/in/trajectory_setpoint: velocity[1] is nan in a velocity setpoint "
            "(NaN position)");
  EXPECT_EQ(v.vehicle.stats().setpoints, 0u);  // none reached the vehicle
  EXPECT_GT(v.vehicle.stats().commands_refused, 0u);
  EXPECT_NE(v.vehicle.stats().last_error.find("no setpoint stream"), std::string::npos)
      << v.vehicle.stats().last_error;
  EXPECT_EQ(v.vehicle.state()[vehicle::kX], 0.0);  // it never moved
}

}  // namespace
}  // namespace ridgeline::px4
