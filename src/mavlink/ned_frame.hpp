// ENU ↔ NED: the one place where Ridgeline's frame meets MAVLink's.
//
// Ridgeline works in a local ENU frame (x east, y north, z up; heading ψ from east,
// counter-clockwise). MAVLink's local frame is NED (x north, y east, z down; yaw from north,
// clockwise). With the same origin:
//
//   NED x = ENU y,   NED y = ENU x,   NED z = −ENU z        (the map is its own inverse)
//   yaw_NED = π/2 − ψ_ENU  (wrapped to (−π, π]),   yaw rate_NED = −ψ̇_ENU
//
// Altitude: with a geodetic origin Ridgeline's z is metres above mean sea level, while PX4's
// local NED frame is centred on the home position, so its z is −(height above home). The home
// altitude h_home (the origin's alt_amsl_m; 0 without an origin, where z is already the height
// above the datum the vehicle's home sits on) is the one offset between the two:
//
//   NED position = (y, x, −(z − h_home))      ENU position = (y_ned, x_ned, h_home − z_ned)
//
// Velocities, headings and rates carry no offset.
//
// The vehicle model's state s = [x, y, z, ψ, v, ω, w] travels as LOCAL_POSITION_NED (position,
// ground velocity) and ATTITUDE (yaw, yaw rate); its command u = [v_c, ω_c, w_c] as
// SET_POSITION_TARGET_LOCAL_NED carrying a velocity (v_c along the current heading, −w_c down)
// and a yaw rate (−ω_c), with type_mask kTypeMaskVelocityYawRate.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "core/types.hpp"
#include "mavlink/messages.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::mavlink {

/// Position or velocity: ENU → NED (and, the map being an involution, NED → ENU).
Vec3 enu_to_ned(const Vec3& enu);
Vec3 ned_to_enu(const Vec3& ned);
/// A position: ENU (z in the scenario's frame) → PX4's local NED about a home at
/// home_altitude_m (in the scenario's z), and back.
Vec3 enu_position_to_ned(const Vec3& enu_m, double home_altitude_m);
Vec3 ned_position_to_enu(const Vec3& ned_m, double home_altitude_m);
/// ψ_ENU (rad from east, counter-clockwise) → yaw_NED (rad from north, clockwise), (−π, π].
double enu_heading_to_ned_yaw(double heading_enu_rad);
double ned_yaw_to_enu_heading(double yaw_ned_rad);

/// What a vehicle reports of its state s at time_boot_ms. The ground velocity includes the
/// wind's drift (ENU, m/s). Roll is 0 and pitch is the flight-path angle atan2(w, v).
struct StateReport {
  LocalPositionNed position;
  Attitude attitude;
};
StateReport report_state(const vehicle::State& state, const Vec3& wind_enu_m_s,
                         std::uint32_t time_boot_ms, double home_altitude_m = 0.0);

/// The model state from a vehicle's reports: position from LOCAL_POSITION_NED, ψ and ω from
/// ATTITUDE's yaw and yaw speed, v the horizontal ground speed, w the climb rate (−vz). Exact
/// for report_state's output without wind; with wind, v and w include its drift.
vehicle::State state_from_report(const LocalPositionNed& position, const Attitude& attitude,
                                 double home_altitude_m = 0.0);

/// The setpoint carrying the command u for a vehicle heading ψ_ENU.
SetPositionTargetLocalNed velocity_setpoint(const vehicle::Input& command, double heading_enu_rad,
                                            std::uint32_t time_boot_ms,
                                            std::uint8_t target_system,
                                            std::uint8_t target_component);

/// Hold: a position setpoint (velocity, acceleration, yaw and yaw rate ignored,
/// kTypeMaskPositionHold) asking the vehicle to stop and hold at `position_enu_m`.
SetPositionTargetLocalNed hold_setpoint(const Vec3& position_enu_m, double home_altitude_m,
                                        std::uint32_t time_boot_ms, std::uint8_t target_system,
                                        std::uint8_t target_component);

/// The command a setpoint carries (v_c = horizontal speed of the velocity, ω_c = −yaw rate,
/// w_c = −vz), or the reason it cannot be flown: error names the field (`coordinate_frame`,
/// `type_mask`, `vx`, ...) and why.
/// A hold setpoint (kTypeMaskPositionHold) gives hold_position_enu_m instead of a command.
struct SetpointCommand {
  std::optional<vehicle::Input> command;
  std::optional<Vec3> hold_position_enu_m;
  std::string error;
};
SetpointCommand command_from_setpoint(const SetPositionTargetLocalNed& setpoint,
                                      double home_altitude_m = 0.0);

}  // namespace ridgeline::mavlink
