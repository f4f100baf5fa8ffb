// PX4's own messages on DDS (issue 22): the px4_msgs types PX4's uXRCE-DDS bridge puts on the
// wire, written from PX4 v1.14's message definitions (msg/*.msg of PX4-Autopilot v1.14.0, the
// release the paper flew; no message there carries a version, so topic names have no `_vN`
// suffix). Each struct has every field of its message, in the message's order and with its
// type (uint64 → std::uint64_t, float32 → float, float32[N] → std::array<float, N>, uint8 →
// std::uint8_t, ...): with @final (XCDR1) types a missing or reordered field would shift every
// byte after it. The IDL module px4_msgs::msg::dds_ (px4_msgs.idl) is generated from these
// lists as Ridgeline's own IDL is (idl_writer.hpp).
//
// Checked field by field (name, type, order) against PX4's published definitions: the v1.14
// message documentation (docs.px4.io/v1.14/en/msg_docs/: VehicleOdometry whole, VehicleStatus up
// to nav_state; OffboardControlMode and TrajectorySetpoint whole), PX4-Autopilot's
// msg/VehicleStatus.msg at 0ebca4e (master after v1.14: the same fields; only the arming-state
// constants were renamed, STANDBY = 1 → DISARMED = 1, ARMED = 2 unchanged; v1.15's
// executor_in_charge, *_nav_states_mask and failsafe_defer_state not yet there) and px4_msgs'
// msg/VehicleCommand.msg at 4b61dce (source_component uint8, as up to v1.14; uint16 from v1.15 on).
// README "PX4's own DDS interface" lists what was checked how.
//
// Frames and units are PX4's: positions and velocities in its local NED frame (x north, y east,
// z down, metres about the home position), angles in radians, yaw from north clockwise, body
// rates in the FRD body frame, timestamps in microseconds since the vehicle's boot. NaN in a
// setpoint field means "not controlled" (PX4's rule): a velocity setpoint has NaN positions.
// No DDS type here: the IDL writer reads this header.
#pragma once

#include <array>
#include <cstdint>

#include "messages/wire_fields.hpp"

namespace ridgeline::transport_dds::px4 {

/// fmu/in/offboard_control_mode: which setpoint kind the companion streams. PX4 stays in (and
/// enters) offboard only while this stream arrives (at least 2 Hz).
struct OffboardControlMode {
  std::uint64_t timestamp = 0;  ///< µs
  bool position = false;
  bool velocity = false;
  bool acceleration = false;
  bool attitude = false;
  bool body_rate = false;
  /// v1.14's last field; later releases split it into thrust_and_torque and direct_actuator.
  bool actuator = false;
};
RIDGELINE_WIRE_FIELDS(OffboardControlMode, "OffboardControlMode", timestamp, position, velocity,
                      acceleration, attitude, body_rate, actuator)

/// fmu/in/trajectory_setpoint: NED; NaN = not controlled.
struct TrajectorySetpoint {
  std::uint64_t timestamp = 0;          ///< µs
  std::array<float, 3> position{};      ///< m, NED
  std::array<float, 3> velocity{};      ///< m/s, NED
  std::array<float, 3> acceleration{};  ///< m/s², NED
  std::array<float, 3> jerk{};          ///< m/s³ (PX4 logs it only)
  float yaw = 0.0f;                     ///< rad from north, clockwise, (−π, π]
  float yawspeed = 0.0f;                ///< rad/s about NED z
};
RIDGELINE_WIRE_FIELDS(TrajectorySetpoint, "TrajectorySetpoint", timestamp, position, velocity,
                      acceleration, jerk, yaw, yawspeed)

/// fmu/in/vehicle_command: MAVLink's COMMAND_LONG as a uORB message (same command numbers).
struct VehicleCommand {
  static constexpr std::uint32_t kDoSetMode = 176;           ///< VEHICLE_CMD_DO_SET_MODE
  static constexpr std::uint32_t kComponentArmDisarm = 400;  ///< VEHICLE_CMD_COMPONENT_ARM_DISARM
  std::uint64_t timestamp = 0;                               ///< µs
  float param1 = 0.0f;
  float param2 = 0.0f;
  float param3 = 0.0f;
  float param4 = 0.0f;
  double param5 = 0.0;
  double param6 = 0.0;
  float param7 = 0.0f;
  std::uint32_t command = 0;
  std::uint8_t target_system = 0;
  std::uint8_t target_component = 0;
  std::uint8_t source_system = 0;
  std::uint8_t source_component = 0;  ///< uint8 up to v1.14 (uint16 from v1.15 on)
  std::uint8_t confirmation = 0;
  bool from_external = false;
};
RIDGELINE_WIRE_FIELDS(VehicleCommand, "VehicleCommand", timestamp, param1, param2, param3, param4,
                      param5, param6, param7, command, target_system, target_component,
                      source_system, source_component, confirmation, from_external)

/// fmu/out/vehicle_odometry: pose and velocity (REP 147 for aerial vehicles).
struct VehicleOdometry {
  static constexpr std::uint8_t kPoseFrameNed = 1;      ///< POSE_FRAME_NED
  static constexpr std::uint8_t kVelocityFrameNed = 1;  ///< VELOCITY_FRAME_NED
  std::uint64_t timestamp = 0;                          ///< µs
  std::uint64_t timestamp_sample = 0;                   ///< µs
  std::uint8_t pose_frame = 0;
  std::array<float, 3> position{};  ///< m, in pose_frame
  std::array<float, 4> q{};         ///< body FRD → pose frame, Hamilton (w, x, y, z)
  std::uint8_t velocity_frame = 0;
  std::array<float, 3> velocity{};              ///< m/s, in velocity_frame
  std::array<float, 3> angular_velocity{};      ///< rad/s, body FRD
  std::array<float, 3> position_variance{};     ///< m²
  std::array<float, 3> orientation_variance{};  ///< rad²
  std::array<float, 3> velocity_variance{};     ///< m²/s²
  std::uint8_t reset_counter = 0;
  std::int8_t quality = 0;
};
RIDGELINE_WIRE_FIELDS(VehicleOdometry, "VehicleOdometry", timestamp, timestamp_sample, pose_frame,
                      position, q, velocity_frame, velocity, angular_velocity, position_variance,
                      orientation_variance, velocity_variance, reset_counter, quality)

/// fmu/out/vehicle_status: the commander's state (arming, navigation mode, ...).
struct VehicleStatus {
  static constexpr std::uint8_t kArmingStateStandby = 1;  ///< ARMING_STATE_STANDBY (v1.14)
  static constexpr std::uint8_t kArmingStateArmed = 2;    ///< ARMING_STATE_ARMED
  static constexpr std::uint8_t kNavStateAutoLoiter = 4;  ///< NAVIGATION_STATE_AUTO_LOITER
  static constexpr std::uint8_t kNavStateOffboard = 14;   ///< NAVIGATION_STATE_OFFBOARD
  static constexpr std::uint8_t kVehicleTypeRotaryWing = 1;
  std::uint64_t timestamp = 0;     ///< µs
  std::uint64_t armed_time = 0;    ///< µs
  std::uint64_t takeoff_time = 0;  ///< µs
  std::uint8_t arming_state = 0;
  std::uint8_t latest_arming_reason = 0;
  std::uint8_t latest_disarming_reason = 0;
  std::uint64_t nav_state_timestamp = 0;  ///< µs
  std::uint8_t nav_state_user_intention = 0;
  std::uint8_t nav_state = 0;
  std::uint16_t failure_detector_status = 0;
  std::uint8_t hil_state = 0;
  std::uint8_t vehicle_type = 0;
  bool failsafe = false;
  bool failsafe_and_user_took_over = false;
  bool gcs_connection_lost = false;
  std::uint8_t gcs_connection_lost_counter = 0;
  bool high_latency_data_link_lost = false;
  bool is_vtol = false;
  bool is_vtol_tailsitter = false;
  bool in_transition_mode = false;
  bool in_transition_to_fw = false;
  std::uint8_t system_type = 0;  ///< MAVLink MAV_TYPE
  std::uint8_t system_id = 0;
  std::uint8_t component_id = 0;
  bool safety_button_available = false;
  bool safety_off = false;
  bool power_input_valid = false;
  bool usb_connected = false;
  bool open_drone_id_system_present = false;
  bool open_drone_id_system_healthy = false;
  bool parachute_system_present = false;
  bool parachute_system_healthy = false;
  bool avoidance_system_required = false;
  bool avoidance_system_valid = false;
  bool rc_calibration_in_progress = false;
  bool calibration_enabled = false;
  bool pre_flight_checks_pass = false;
};
RIDGELINE_WIRE_FIELDS(VehicleStatus, "VehicleStatus", timestamp, armed_time, takeoff_time,
                      arming_state, latest_arming_reason, latest_disarming_reason,
                      nav_state_timestamp, nav_state_user_intention, nav_state,
                      failure_detector_status, hil_state, vehicle_type, failsafe,
                      failsafe_and_user_took_over, gcs_connection_lost, gcs_connection_lost_counter,
                      high_latency_data_link_lost, is_vtol, is_vtol_tailsitter, in_transition_mode,
                      in_transition_to_fw, system_type, system_id, component_id,
                      safety_button_available, safety_off, power_input_valid, usb_connected,
                      open_drone_id_system_present, open_drone_id_system_healthy,
                      parachute_system_present, parachute_system_healthy, avoidance_system_required,
                      avoidance_system_valid, rc_calibration_in_progress, calibration_enabled,
                      pre_flight_checks_pass)

}  // namespace ridgeline::transport_dds::px4
