// Between PX4's px4_msgs (transport_dds/px4_messages.hpp) and the MAVLink path's messages
// (mavlink/messages.hpp), so the PX4 DDS path reuses what the MAVLink path already owns: the
// ENU↔NED conversions and the command ↔ setpoint mapping (mavlink/ned_frame.hpp), the lock-step
// clock and the simulated vehicle. Both wires carry the same quantities in PX4's local NED frame
// about home; px4_msgs adds microsecond timestamps, NaN for "not controlled" and an attitude
// quaternion instead of Euler angles.
//
//   TrajectorySetpoint   velocity + yawspeed, NaN position  ↔  type_mask kTypeMaskVelocityYawRate
//                        position, NaN velocity and yawspeed ↔  type_mask kTypeMaskPositionHold
//   VehicleOdometry      position, velocity (NED), q = Rz(yaw)·Ry(pitch) (roll 0, FRD body →
//                        NED), angular_velocity = body rates: r = yaw rate·cos(pitch)
//                        ↔ LOCAL_POSITION_NED + ATTITUDE
//   VehicleStatus        arming_state ARMED, nav_state OFFBOARD ↔ HEARTBEAT's armed / offboard
//   VehicleCommand       the same command numbers and params as COMMAND_LONG
// Timestamps: µs = 1000 · the MAVLink path's ms (in lock step, the vehicle's time); the
// keep-alive stamp (never a step) is the largest uint64.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "mavlink/lockstep_fleet.hpp"
#include "mavlink/messages.hpp"
#include "mavlink/ned_frame.hpp"
#include "mavlink/simulated_vehicle.hpp"
#include "transport_dds/px4_messages.hpp"

namespace ridgeline::px4 {

namespace msg = transport_dds::px4;

/// The keep-alive stamp of a lock-step TrajectorySetpoint (SimulatedVehicle::kKeepAliveStamp).
inline constexpr std::uint64_t kKeepAliveStampUs = ~std::uint64_t{0};
std::uint64_t stamp_us(std::uint32_t stamp_ms);

/// The TrajectorySetpoint of a velocity + yaw-rate or position-hold setpoint, stamped `stamp_us`.
msg::TrajectorySetpoint trajectory_setpoint(const mavlink::SetPositionTargetLocalNed& setpoint,
                                            std::uint64_t stamp);

/// The SET_POSITION_TARGET_LOCAL_NED a TrajectorySetpoint asks for, or why it cannot be flown
/// (error names the field: "velocity[1] is NaN", ...). A velocity setpoint needs a finite
/// velocity and yawspeed, a hold a finite position; anything else is refused.
struct SetpointFromPx4 {
  std::optional<mavlink::SetPositionTargetLocalNed> setpoint;
  std::string error;
};
SetpointFromPx4 setpoint_from_px4(const msg::TrajectorySetpoint& setpoint);

/// The odometry of a vehicle's state report, stamped `stamp`.
msg::VehicleOdometry odometry(const mavlink::StateReport& report, std::uint64_t stamp);

/// A fleet report (ENU) from odometry, or why it cannot be used (error names the field: NaN,
/// a frame that is not NED, a quaternion that is not a rotation).
struct ReportFromPx4 {
  std::optional<mavlink::FleetReport> report;
  std::string error;
};
ReportFromPx4 report_from_px4(const msg::VehicleOdometry& odometry, double home_altitude_m);

/// LOCAL_POSITION_NED + ATTITUDE from odometry (the inverse of odometry(): yaw and pitch from
/// q, yaw speed = angular_velocity[2] / cos(pitch)), stamped time_boot_ms, or why it cannot be
/// used (the same refusals as report_from_px4). For the real-time companion (px4_pilot.hpp),
/// whose OffboardPilot reads the MAVLink path's messages.
struct StateFromPx4 {
  std::optional<mavlink::StateReport> report;
  std::string error;
};
StateFromPx4 state_report_from_px4(const msg::VehicleOdometry& odometry,
                                   std::uint32_t time_boot_ms);

/// A vehicle's status: armed or standby, offboard or loiter.
msg::VehicleStatus vehicle_status(bool armed, bool offboard, std::uint64_t stamp);
bool status_armed(const msg::VehicleStatus& status);
bool status_offboard(const msg::VehicleStatus& status);
/// The HEARTBEAT that says the same (SAFETY_ARMED, PX4 main mode OFFBOARD).
mavlink::Heartbeat heartbeat_from_px4(const msg::VehicleStatus& status);

/// VEHICLE_CMD_COMPONENT_ARM_DISARM (arm) and VEHICLE_CMD_DO_SET_MODE (PX4 offboard).
msg::VehicleCommand arm_command(std::uint8_t target_system, std::uint64_t stamp);
msg::VehicleCommand offboard_command(std::uint8_t target_system, std::uint64_t stamp);
/// The COMMAND_LONG with the same command and params, and back (stamped `stamp`, from the
/// onboard computer: source component 191, from_external).
mavlink::CommandLong command_long(const msg::VehicleCommand& command);
msg::VehicleCommand vehicle_command(const mavlink::CommandLong& command, std::uint64_t stamp);

/// The offboard control mode of a velocity (or, for a hold, position) setpoint stream.
msg::OffboardControlMode offboard_control_mode(bool position, std::uint64_t stamp);

}  // namespace ridgeline::px4
