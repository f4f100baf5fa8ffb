#include "px4/px4_frame.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

namespace ridgeline::px4 {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr std::array<float, 3> kNaN3{kNaN, kNaN, kNaN};

bool all_nan(const std::array<float, 3>& v) {
  return std::isnan(v[0]) && std::isnan(v[1]) && std::isnan(v[2]);
}

/// "name[k] is NaN" for the first element of v that is not finite ("" when all are).
template <std::size_t N>
std::string first_not_finite(const char* name, const std::array<float, N>& v) {
  for (std::size_t k = 0; k < N; ++k)
    if (!std::isfinite(v[k])) return fmt::format("{}[{}] is {}", name, k, v[k]);
  return "";
}

}  // namespace

std::uint64_t stamp_us(std::uint32_t stamp_ms) {
  return stamp_ms == mavlink::SimulatedVehicle::kKeepAliveStamp ? kKeepAliveStampUs
                                                                : std::uint64_t{stamp_ms} * 1000u;
}

msg::TrajectorySetpoint trajectory_setpoint(const mavlink::SetPositionTargetLocalNed& sp,
                                            std::uint64_t stamp) {
  msg::TrajectorySetpoint t;
  t.timestamp = stamp;
  t.acceleration = t.jerk = kNaN3;
  t.yaw = kNaN;
  if (sp.type_mask == mavlink::kTypeMaskPositionHold) {
    t.position = {sp.x, sp.y, sp.z};
    t.velocity = kNaN3;
    t.yawspeed = kNaN;
  } else {
    t.position = kNaN3;
    t.velocity = {sp.vx, sp.vy, sp.vz};
    t.yawspeed = sp.yaw_rate;
  }
  return t;
}

SetpointFromPx4 setpoint_from_px4(const msg::TrajectorySetpoint& t) {
  mavlink::SetPositionTargetLocalNed sp;
  sp.time_boot_ms = t.timestamp == kKeepAliveStampUs
                        ? mavlink::SimulatedVehicle::kKeepAliveStamp
                        : static_cast<std::uint32_t>(t.timestamp / 1000u);
  sp.target_system = sp.target_component = 1;
  if (all_nan(t.position)) {
    // A velocity setpoint: the command u (ned_frame.hpp's velocity_setpoint).
    std::string error = first_not_finite("velocity", t.velocity);
    if (error.empty() && !std::isfinite(t.yawspeed))
      error = fmt::format("yawspeed is {}", t.yawspeed);
    if (!error.empty()) return {std::nullopt, error + " in a velocity setpoint (NaN position)"};
    sp.type_mask = mavlink::kTypeMaskVelocityYawRate;
    sp.vx = t.velocity[0];
    sp.vy = t.velocity[1];
    sp.vz = t.velocity[2];
    sp.yaw_rate = t.yawspeed;
    return {sp, ""};
  }
  if (!all_nan(t.velocity))
    return {std::nullopt,
            "position and velocity both set: a setpoint is a velocity (NaN position) or a hold "
            "(NaN velocity)"};
  if (std::string error = first_not_finite("position", t.position); !error.empty())
    return {std::nullopt, error + " in a hold (NaN velocity)"};
  sp.type_mask = mavlink::kTypeMaskPositionHold;
  sp.x = t.position[0];
  sp.y = t.position[1];
  sp.z = t.position[2];
  return {sp, ""};
}

msg::VehicleOdometry odometry(const mavlink::StateReport& r, std::uint64_t stamp) {
  msg::VehicleOdometry o;
  o.timestamp = o.timestamp_sample = stamp;
  o.pose_frame = msg::VehicleOdometry::kPoseFrameNed;
  o.velocity_frame = msg::VehicleOdometry::kVelocityFrameNed;
  o.position = {r.position.x, r.position.y, r.position.z};
  o.velocity = {r.position.vx, r.position.vy, r.position.vz};
  // q = Rz(yaw)·Ry(pitch) with roll 0, half angles (Hamilton, w first).
  const double half_yaw = 0.5 * r.attitude.yaw, half_pitch = 0.5 * r.attitude.pitch;
  o.q = {static_cast<float>(std::cos(half_yaw) * std::cos(half_pitch)),
         static_cast<float>(-std::sin(half_yaw) * std::sin(half_pitch)),
         static_cast<float>(std::cos(half_yaw) * std::sin(half_pitch)),
         static_cast<float>(std::sin(half_yaw) * std::cos(half_pitch))};
  // Body rates with roll 0: r = yaw rate·cos(pitch).
  o.angular_velocity = {r.attitude.rollspeed, r.attitude.pitchspeed,
                        static_cast<float>(r.attitude.yawspeed * std::cos(r.attitude.pitch))};
  o.position_variance = o.orientation_variance = o.velocity_variance = kNaN3;
  return o;
}

namespace {

/// Why odometry cannot be flown on ("" when it can): a frame that is not NED, a value that is
/// not finite, a quaternion that is not a rotation.
std::string odometry_error(const msg::VehicleOdometry& o) {
  if (o.pose_frame != msg::VehicleOdometry::kPoseFrameNed)
    return fmt::format("pose_frame {} is not NED (1)", o.pose_frame);
  if (o.velocity_frame != msg::VehicleOdometry::kVelocityFrameNed)
    return fmt::format("velocity_frame {} is not NED (1)", o.velocity_frame);
  for (const std::string& error :
       {first_not_finite("position", o.position), first_not_finite("velocity", o.velocity),
        first_not_finite("q", o.q), first_not_finite("angular_velocity", o.angular_velocity)})
    if (!error.empty()) return error;
  const double w = o.q[0], x = o.q[1], y = o.q[2], z = o.q[3];
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  if (std::abs(norm - 1.0) > 1e-3) return fmt::format("q has norm {:.6f}, not a rotation", norm);
  return "";
}

/// Yaw (from north, clockwise) and pitch of q = Rz(yaw)·Ry(pitch)·Rx(roll).
std::pair<double, double> yaw_pitch(const std::array<float, 4>& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)),
          std::asin(std::clamp(2.0 * (w * y - z * x), -1.0, 1.0))};
}

}  // namespace

ReportFromPx4 report_from_px4(const msg::VehicleOdometry& o, double home_altitude_m) {
  if (std::string error = odometry_error(o); !error.empty()) return {std::nullopt, error};
  const auto [yaw, pitch] = yaw_pitch(o.q);
  mavlink::FleetReport r;
  r.position_m = mavlink::ned_position_to_enu(Vec3(o.position[0], o.position[1], o.position[2]),
                                              home_altitude_m);
  r.ground_velocity_m_s = mavlink::ned_to_enu(Vec3(o.velocity[0], o.velocity[1], o.velocity[2]));
  r.heading_rad = mavlink::ned_yaw_to_enu_heading(yaw);
  r.turn_rate_rad_s = -static_cast<double>(o.angular_velocity[2]) / std::cos(pitch);
  return {r, ""};
}

StateFromPx4 state_report_from_px4(const msg::VehicleOdometry& o, std::uint32_t time_boot_ms) {
  if (std::string error = odometry_error(o); !error.empty()) return {std::nullopt, error};
  const auto [yaw, pitch] = yaw_pitch(o.q);
  mavlink::StateReport r;
  r.position.time_boot_ms = r.attitude.time_boot_ms = time_boot_ms;
  r.position.x = o.position[0];
  r.position.y = o.position[1];
  r.position.z = o.position[2];
  r.position.vx = o.velocity[0];
  r.position.vy = o.velocity[1];
  r.position.vz = o.velocity[2];
  r.attitude.yaw = static_cast<float>(yaw);
  r.attitude.pitch = static_cast<float>(pitch);
  r.attitude.rollspeed = o.angular_velocity[0];
  r.attitude.pitchspeed = o.angular_velocity[1];
  r.attitude.yawspeed = static_cast<float>(o.angular_velocity[2] / std::cos(pitch));
  return {r, ""};
}

msg::VehicleStatus vehicle_status(bool armed, bool offboard, std::uint64_t stamp) {
  msg::VehicleStatus s;
  s.timestamp = stamp;
  s.arming_state =
      armed ? msg::VehicleStatus::kArmingStateArmed : msg::VehicleStatus::kArmingStateStandby;
  s.nav_state = s.nav_state_user_intention =
      offboard ? msg::VehicleStatus::kNavStateOffboard : msg::VehicleStatus::kNavStateAutoLoiter;
  s.vehicle_type = msg::VehicleStatus::kVehicleTypeRotaryWing;
  s.system_type = mavlink::kMavTypeHexarotor;
  s.system_id = s.component_id = 1;
  s.pre_flight_checks_pass = true;
  return s;
}

bool status_armed(const msg::VehicleStatus& s) {
  return s.arming_state == msg::VehicleStatus::kArmingStateArmed;
}
bool status_offboard(const msg::VehicleStatus& s) {
  return s.nav_state == msg::VehicleStatus::kNavStateOffboard;
}

mavlink::Heartbeat heartbeat_from_px4(const msg::VehicleStatus& s) {
  mavlink::Heartbeat h;
  h.type = s.system_type;
  h.autopilot = mavlink::kMavAutopilotPx4;
  h.base_mode = static_cast<std::uint8_t>(mavlink::kModeFlagCustomModeEnabled |
                                          (status_armed(s) ? mavlink::kModeFlagSafetyArmed : 0));
  h.custom_mode = status_offboard(s) ? mavlink::kPx4CustomModeOffboard : 0;
  h.system_status = status_armed(s) ? mavlink::kMavStateActive : mavlink::kMavStateStandby;
  return h;
}

namespace {
msg::VehicleCommand command(std::uint32_t id, std::uint8_t target_system, std::uint64_t stamp) {
  msg::VehicleCommand c;
  c.timestamp = stamp;
  c.command = id;
  c.target_system = target_system;
  c.target_component = 1;
  c.source_system = 1;
  c.source_component = 191;  // MAV_COMP_ID_ONBOARD_COMPUTER, as the MAVLink companion
  c.from_external = true;
  return c;
}
}  // namespace

msg::VehicleCommand arm_command(std::uint8_t target_system, std::uint64_t stamp) {
  msg::VehicleCommand c = command(msg::VehicleCommand::kComponentArmDisarm, target_system, stamp);
  c.param1 = 1.0f;
  return c;
}

msg::VehicleCommand offboard_command(std::uint8_t target_system, std::uint64_t stamp) {
  msg::VehicleCommand c = command(msg::VehicleCommand::kDoSetMode, target_system, stamp);
  c.param1 = static_cast<float>(mavlink::kModeFlagCustomModeEnabled);
  c.param2 = static_cast<float>(mavlink::kPx4MainModeOffboard);
  return c;
}

mavlink::CommandLong command_long(const msg::VehicleCommand& c) {
  mavlink::CommandLong l;
  l.command = static_cast<std::uint16_t>(c.command);
  l.param1 = c.param1;
  l.param2 = c.param2;
  l.param3 = c.param3;
  l.param4 = c.param4;
  l.param5 = static_cast<float>(c.param5);
  l.param6 = static_cast<float>(c.param6);
  l.param7 = c.param7;
  l.target_system = c.target_system;
  l.target_component = c.target_component;
  l.confirmation = c.confirmation;
  return l;
}

msg::VehicleCommand vehicle_command(const mavlink::CommandLong& l, std::uint64_t stamp) {
  msg::VehicleCommand c = command(l.command, l.target_system, stamp);
  c.target_component = l.target_component;
  c.param1 = l.param1;
  c.param2 = l.param2;
  c.param3 = l.param3;
  c.param4 = l.param4;
  c.param5 = l.param5;
  c.param6 = l.param6;
  c.param7 = l.param7;
  c.confirmation = l.confirmation;
  return c;
}

msg::OffboardControlMode offboard_control_mode(bool position, std::uint64_t stamp) {
  msg::OffboardControlMode m;
  m.timestamp = stamp;
  m.position = position;
  m.velocity = !position;
  return m;
}

}  // namespace ridgeline::px4
