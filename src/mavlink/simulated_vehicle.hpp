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
//    arming or mode is announced by a HEARTBEAT with the next report (there is no COMMAND_ACK).
//    Like PX4, it refuses offboard unless setpoints are streaming (one within setpoint_timeout_s),
//    and leaves offboard (and holds) when they stop for longer than that;
//  - SET_POSITION_TARGET_LOCAL_NED: the command u = [v_c, ω_c, w_c] (ned_frame.hpp); a
//    setpoint it cannot fly is counted with its reason, never flown.
//  - a position setpoint (kTypeMaskPositionHold) within hold_tolerance_m of the vehicle makes
//    it stop and hold there (v = ω = w = 0 at once, as the mission's truth holds a finished UAV);
//    the next velocity setpoint releases it at the commanded speed.
// While not armed and in offboard it hovers where it is (v = ω = w = 0, heading kept).
// With a wind field it drifts with the wind W(p, t) of the field at its time (eq. 1, sampled at
// each RK4 step's start, as mission::TruthWorld does) and reports its ground velocity.
// Time is whatever the caller says (seconds since start), so it runs in lock step in tests
// and on the wall clock in `ridgeline vehicle-sim`.
//
// Lock step (as PX4 SITL's lockstep, but driven by the companion's setpoints): with
// handle_lockstep() the vehicle's clock moves only when a setpoint asks it to. Its time is
// k·period_s after k steps flown; a setpoint stamped (time_boot_ms) with the vehicle's own time
// ms(k) = round(1000·k·period_s) while it flies (armed, offboard) is applied and the model
// advances exactly one period; one stamped ms(k − 1) (the companion resent it because the answer
// was lost) advances nothing; one stamped kKeepAliveStamp, or any while not flying, only keeps
// the setpoint stream alive for offboard. lockstep_reply() is the answer to a datagram:
// HEARTBEAT, LOCAL_POSITION_NED and ATTITUDE stamped ms(k). Time 0 is the start of offboard.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mavlink/frame.hpp"
#include "mavlink/messages.hpp"
#include "mavlink/ned_frame.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/wind.hpp"

namespace ridgeline::mavlink {

struct SimulatedVehicleOptions {
  vehicle::VehicleParams params;                 ///< the truth's model
  vehicle::State initial_state = vehicle::State::Zero();  ///< ENU; v, ω, w are zeroed (hover)
  double integration_step_s = 0.005;  ///< RK4 step (200 Hz, as the mission's truth)
  double report_period_s = 0.02;      ///< LOCAL_POSITION_NED + ATTITUDE (50 Hz)
  double heartbeat_period_s = 1.0;
  double setpoint_timeout_s = 0.5;    ///< offboard needs a setpoint at least this recent
  /// The wind that drifts the vehicle (e.g. the scenario's seeded field, the same as the
  /// mission's truth); none: still air.
  std::optional<world::WindConfig> wind;
  /// Horizontal speed (m/s) along its heading when offboard starts: a UAV already at cruise
  /// when the mission starts, as mission::TruthWorld starts it (hover lies outside the motion
  /// model's speed band, eq. 2). 0: it leaves the hover at rest.
  double offboard_entry_speed_m_s = 0.0;
  /// The home position's altitude in the initial state's z (ned_frame.hpp): reports and
  /// position setpoints are in PX4's local NED about it.
  double home_altitude_m = 0.0;
  double hold_tolerance_m = 5.0;  ///< a hold setpoint farther than this is refused
  std::uint8_t system_id = 1;
  std::uint8_t component_id = 1;      ///< MAV_COMP_ID_AUTOPILOT1
};

struct SimulatedVehicleStats {
  std::uint64_t setpoints = 0;
  std::uint64_t setpoints_rejected = 0;
  std::uint64_t commands = 0;
  std::uint64_t commands_refused = 0;
  std::uint64_t offboard_timeouts = 0;
  std::uint64_t holds = 0;
  std::uint64_t lockstep_steps = 0;       ///< periods advanced by lock-step setpoints
  std::uint64_t lockstep_duplicates = 0;  ///< resent setpoints answered without advancing
  std::uint64_t lockstep_out_of_step = 0; ///< setpoints stamped neither ms(k) nor ms(k − 1)
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
  /// The same as messages, for a vehicle served on another wire (PX4's DDS topics,
  /// px4/px4_vehicle.hpp).
  void advance(double t_s, std::vector<Message>& out);

  /// Setpoints stamped with this are stream keep-alives in lock step, never a step.
  static constexpr std::uint32_t kKeepAliveStamp = 0xFFFFFFFFu;
  /// Lock step (see the header comment): one received message. period_s > 0.
  void handle_lockstep(const Message& message, double period_s);
  /// Lock step: the answer to a datagram (HEARTBEAT, LOCAL_POSITION_NED, ATTITUDE at ms(k)).
  void lockstep_reply(std::vector<EncodedFrame>& out);
  /// Lock step: the state report of that answer (LOCAL_POSITION_NED and ATTITUDE at ms(k)), for
  /// a vehicle that answers on another wire (PX4's DDS topics, px4/px4_vehicle.hpp).
  StateReport lockstep_state_report() const;
  /// ms(k) = round(1000·k·period_s): a lock-step time stamp (shared with the companion).
  static std::uint32_t lockstep_stamp_ms(std::uint64_t step, double period_s);

  const vehicle::State& state() const { return state_; }
  bool armed() const { return armed_; }
  bool offboard() const { return offboard_; }
  bool holding() const { return holding_; }
  double time_s() const { return t_; }
  /// How recent the offboard stream must be for offboard (PX4's offboard loss timeout).
  double setpoint_timeout_s() const { return o_.setpoint_timeout_s; }
  const SimulatedVehicleStats& stats() const { return stats_; }

 private:
  void integrate_to(double t_s);
  void handle_command(const CommandLong& c, double t_s);
  void handle_setpoint(const SetPositionTargetLocalNed& sp, double t_s);
  Vec3 wind_at_vehicle() const;
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
  bool holding_ = false;
  std::optional<world::WindField> wind_;
  std::uint64_t lockstep_step_ = 0;
  double lockstep_period_s_ = 0.0;
  std::uint8_t sequence_ = 0;
  SimulatedVehicleStats stats_;
};

}  // namespace ridgeline::mavlink
