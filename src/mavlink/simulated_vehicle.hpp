// A MAVLink vehicle for tests: the stand-in for PX4 SITL (which Debian does not package).
//
// It integrates the vehicle model (vehicle_model.hpp, RK4) from the velocity + yaw-rate
// setpoints it receives and behaves like a PX4 multicopter in the ways an offboard companion
// depends on:
//  - HEARTBEAT every heartbeat_period_s (1 Hz): MAV_TYPE_HEXAROTOR, MAV_AUTOPILOT_PX4,
//    base_mode with SAFETY_ARMED when armed and CUSTOM_MODE_ENABLED, custom_mode = PX4 main mode
//    in bits 16–23 (OFFBOARD = 6), system_status STANDBY or ACTIVE;
//  - LOCAL_POSITION_NED and ATTITUDE every report_period_s (50 Hz);
//  - COMMAND_LONG MAV_CMD_COMPONENT_ARM_DISARM (param1 1 arms, 0 disarms) and MAV_CMD_DO_SET_MODE
//    (param1 with CUSTOM_MODE_ENABLED, param2 = main mode 6) to enter offboard; a change of
//    arming or mode is announced by a HEARTBEAT with the next report (there is no COMMAND_ACK). Like PX4, it
//    refuses offboard unless setpoints are streaming (one within setpoint_timeout_s), and
//    leaves offboard (and holds) when they stop for longer than that;
//  - SET_POSITION_TARGET_LOCAL_NED: the command u = [v_c, ω_c, w_c] (ned_frame.hpp); a
//    setpoint it cannot fly is counted with its reason, never flown.
// While not armed and in offboard it hovers where it is (v = ω = w = 0, heading kept).
// Time is whatever the caller says (seconds since start), so it runs in lock step in tests
// and on the wall clock in `ridgeline vehicle-sim`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mavlink/frame.hpp"
#include "mavlink/messages.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::mavlink {

struct SimulatedVehicleOptions {
  vehicle::VehicleParams params;                 ///< the truth's model
  vehicle::State initial_state = vehicle::State::Zero();  ///< ENU; v, ω, w are zeroed (hover)
  double integration_step_s = 0.005;  ///< RK4 step (200 Hz, as the mission's truth)
  double report_period_s = 0.02;      ///< LOCAL_POSITION_NED + ATTITUDE (50 Hz)
  double heartbeat_period_s = 1.0;
  double setpoint_timeout_s = 0.5;    ///< offboard needs a setpoint at least this recent
  std::uint8_t system_id = 1;
  std::uint8_t component_id = 1;      ///< MAV_COMP_ID_AUTOPILOT1
};

struct SimulatedVehicleStats {
  std::uint64_t setpoints = 0;
  std::uint64_t setpoints_rejected = 0;
  std::uint64_t commands = 0;
  std::uint64_t commands_refused = 0;
  std::uint64_t offboard_timeouts = 0;
  std::string last_error;  ///< why the last setpoint or command was refused
};

class SimulatedVehicle {
 public:
  /// Throws ridgeline::InputError naming the option for non-positive periods.
  explicit SimulatedVehicle(const SimulatedVehicleOptions& options);

  /// A message received at time t_s (integrates up to t_s first).
  void handle(const Message& message, double t_s);
  /// Integrates to t_s and appends the reports due by then to `out`.
  void advance(double t_s, std::vector<EncodedFrame>& out);

  const vehicle::State& state() const { return state_; }
  bool armed() const { return armed_; }
  bool offboard() const { return offboard_; }
  double time_s() const { return t_; }
  const SimulatedVehicleStats& stats() const { return stats_; }

 private:
  void integrate_to(double t_s);
  void handle_command(const CommandLong& c, double t_s);
  Heartbeat heartbeat() const;
  FrameHeader next_header();

  SimulatedVehicleOptions o_;
  vehicle::State state_;
  vehicle::Input command_ = vehicle::Input::Zero();
  double t_ = 0.0;
  double last_setpoint_s_ = -1e300;
  double next_report_s_ = 0.0;
  double next_heartbeat_s_ = 0.0;
  bool armed_ = false;
  bool offboard_ = false;
  std::uint8_t sequence_ = 0;
  SimulatedVehicleStats stats_;
};

}  // namespace ridgeline::mavlink
