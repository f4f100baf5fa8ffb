// The offboard pilot and the simulated vehicle (src/mavlink/offboard_pilot.*,
// simulated_vehicle.*) talking MAVLink frames to each other in lock step: every byte goes
// through the encoder and a StreamParser on the other side, as over UDP, but with simulated
// time so a 30 s flight takes well under a second.
#include "mavlink/offboard_pilot.hpp"

#include <gtest/gtest.h>

#include "mavlink/ned_frame.hpp"
#include "mavlink/simulated_vehicle.hpp"
#include "mavlink/stream_parser.hpp"

namespace ridgeline::mavlink {
namespace {

struct Loopback {
  SimulatedVehicle vehicle;
  OffboardPilot pilot;
  StreamParser to_vehicle, to_pilot;
  std::vector<EncodedFrame> out;
  std::uint64_t frames_to_vehicle = 0, frames_to_pilot = 0;

  void step(double t, bool pilot_alive = true) {
    vehicle.advance(t, out);
    for (const EncodedFrame& f : out)
      to_pilot.push(f.view(), [&](const Frame& fr) {
        ++frames_to_pilot;
        if (pilot_alive) pilot.handle(*decode_message(fr), t);
      });
    out.clear();
    if (!pilot_alive) return;
    pilot.tick(t, out);
    for (const EncodedFrame& f : out)
      to_vehicle.push(f.view(), [&](const Frame& fr) {
        ++frames_to_vehicle;
        vehicle.handle(*decode_message(fr), t);
      });
    out.clear();
  }
};

vehicle::State start_state() {
  vehicle::State s = vehicle::State::Zero();
  s[vehicle::kZ] = 100.0;  // heading east (ψ = 0) at 100 m
  return s;
}

std::shared_ptr<const mpc::ReferenceTrajectory> left_circle() {
  // Starts at the vehicle (0, 0, 100) heading east and turns left on a 150 m circle at 10 m/s.
  return std::make_shared<mpc::HelixReference>(mpc::HelixReference::Config{
      .centre_m = Vec3(0.0, 150.0, 100.0), .radius_m = 150.0, .speed_m_s = 10.0,
      .climb_rate_m_s = 0.0, .phase0_rad = -0.5 * kPi, .turn_left = true, .t0_s = 0.0});
}

// The whole protocol: arm, offboard only once setpoints stream, then the tracker flies the
// circle from a hover start. After the first seconds (the vehicle starts at rest while the
// reference already moves at 10 m/s, so it falls ≈ v·τ_v behind before catching up) the
// tracking error must vanish: the MAVLink path only adds float rounding of the state.
TEST(OffboardPilot, ArmsStartsOffboardAndTracksACircleThroughMavlinkFrames) {
  SimulatedVehicleOptions vo;
  vo.initial_state = start_state();
  // The vehicle's lags 20 % slower than the tracker's model, as the mission's truth has them.
  vo.params.tau_v_s *= 1.2;
  vo.params.tau_omega_s *= 1.2;
  vo.params.tau_w_s *= 1.2;
  OffboardPilotOptions po;
  po.flight_duration_s = 30.0;
  Loopback link{SimulatedVehicle(vo),
                OffboardPilot(po, world::SafetyLimits{}, left_circle(), nullptr),
                {},
                {},
                {}};
  double t = 0.0;
  for (; t < 40.0 && !link.pilot.done(); t += 0.02) link.step(t);
  const FlightSummary s = link.pilot.summary();
  EXPECT_EQ(s.phase, PilotPhase::kFinished);
  EXPECT_TRUE(link.vehicle.armed());
  EXPECT_LT(s.time_to_offboard_s, 0.2);  // each change is announced with the next report
  EXPECT_NEAR(s.flown_time_s, 30.0, 0.05);
  EXPECT_EQ(s.stale_steps, 0);
  EXPECT_EQ(link.vehicle.stats().setpoints_rejected, 0u) << link.vehicle.stats().last_error;
  EXPECT_EQ(link.to_vehicle.stats().rejected() + link.to_pilot.stats().rejected(), 0u);
  double max_late_error = 0.0;
  for (const FlightSample& f : link.pilot.log()) {
    if (f.t_s > 10.0) max_late_error = std::max(max_late_error, (f.position_m - f.reference_m).norm());
  }
  std::printf("lock-step flight: %d steps, time to offboard %.2f s, RMSE %.2f m, max %.2f m, "
              "max after 10 s %.3f m, %.0f m flown; frames %llu to the vehicle, %llu to the pilot\n",
              s.steps, s.time_to_offboard_s, s.tracking_rmse_m, s.tracking_max_m, max_late_error,
              s.path_length_m, static_cast<unsigned long long>(link.frames_to_vehicle),
              static_cast<unsigned long long>(link.frames_to_pilot));
  EXPECT_LT(s.tracking_max_m, 8.0);   // the start lag: 10 m/s × τ_v 0.5 s plus the catch-up
  // Offset-free in the steady turn despite the lag mismatch (the incremental form's integral
  // action); what is left is the reports' float rounding (~1e-5 m at 150 m).
  EXPECT_LT(max_late_error, 0.05);
  EXPECT_GT(s.path_length_m, 0.9 * 10.0 * 30.0);
  // The vehicle really is where the pilot's log says (the log is read from its reports).
  const vehicle::State& v = link.vehicle.state();
  EXPECT_LT((v.head<3>() - link.pilot.log().back().position_m).norm(), 0.5);
}

TEST(SimulatedVehicle, RefusesOffboardWithoutASetpointStreamAndSaysWhy) {
  SimulatedVehicleOptions vo;
  vo.initial_state = start_state();
  SimulatedVehicle vehicle(vo);
  CommandLong arm;
  arm.command = kMavCmdComponentArmDisarm;
  arm.param1 = 1.0f;
  arm.target_system = 1;
  vehicle.handle(arm, 0.1);
  EXPECT_TRUE(vehicle.armed());
  CommandLong offboard;
  offboard.command = kMavCmdDoSetMode;
  offboard.param1 = 1.0f;
  offboard.param2 = 6.0f;
  offboard.target_system = 1;
  vehicle.handle(offboard, 0.2);
  EXPECT_FALSE(vehicle.offboard());
  EXPECT_NE(vehicle.stats().last_error.find("no setpoint stream"), std::string::npos)
      << vehicle.stats().last_error;
  vehicle.handle(velocity_setpoint(vehicle::Input(10, 0, 0), 0.0, 300, 1, 1), 0.3);
  vehicle.handle(offboard, 0.35);
  EXPECT_TRUE(vehicle.offboard());
  // The stream stops: after setpoint_timeout_s the vehicle leaves offboard and hovers.
  std::vector<EncodedFrame> out;
  vehicle.advance(0.6, out);
  EXPECT_TRUE(vehicle.offboard());
  EXPECT_GT(vehicle.state()[vehicle::kX], 0.0);  // it flew east meanwhile
  vehicle.advance(1.0, out);
  EXPECT_FALSE(vehicle.offboard());
  EXPECT_EQ(vehicle.stats().offboard_timeouts, 1u);
  EXPECT_EQ(vehicle.state()[vehicle::kV], 0.0);
  // A mode it does not have, and a setpoint it cannot fly: refused with the reason.
  offboard.param2 = 4.0f;
  vehicle.handle(offboard, 1.1);
  EXPECT_NE(vehicle.stats().last_error.find("is not PX4 offboard"), std::string::npos);
  SetPositionTargetLocalNed position_sp = velocity_setpoint(vehicle::Input(10, 0, 0), 0.0, 0, 1, 1);
  position_sp.type_mask = 0;
  vehicle.handle(position_sp, 1.2);
  EXPECT_EQ(vehicle.stats().setpoints_rejected, 1u);
  EXPECT_NE(vehicle.stats().last_error.find("SET_POSITION_TARGET_LOCAL_NED.type_mask"),
            std::string::npos)
      << vehicle.stats().last_error;
}

// When the vehicle drops out of offboard mid-flight (here: the companion goes silent for a
// second, so the vehicle's failsafe takes over), the pilot stops and says so.
TEST(OffboardPilot, StopsWhenTheVehicleLeavesOffboard) {
  SimulatedVehicleOptions vo;
  vo.initial_state = start_state();
  OffboardPilotOptions po;
  po.flight_duration_s = 30.0;
  Loopback link{SimulatedVehicle(vo),
                OffboardPilot(po, world::SafetyLimits{}, left_circle(), nullptr),
                {},
                {},
                {}};
  double t = 0.0;
  for (; t < 5.0; t += 0.02) link.step(t);
  ASSERT_EQ(link.pilot.phase(), PilotPhase::kFlying);
  for (; t < 6.0; t += 0.02) link.step(t, /*pilot_alive=*/false);
  EXPECT_FALSE(link.vehicle.offboard());
  for (; t < 8.5 && !link.pilot.done(); t += 0.02) link.step(t);  // next heartbeat within 1 s
  EXPECT_EQ(link.pilot.phase(), PilotPhase::kVehicleLeftOffboard);
}

}  // namespace
}  // namespace ridgeline::mavlink
