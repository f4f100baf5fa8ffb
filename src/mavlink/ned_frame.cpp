#include "mavlink/ned_frame.hpp"

#include <cmath>

#include <fmt/format.h>

namespace ridgeline::mavlink {

Vec3 enu_to_ned(const Vec3& enu) { return {enu.y(), enu.x(), -enu.z()}; }
Vec3 ned_to_enu(const Vec3& ned) { return {ned.y(), ned.x(), -ned.z()}; }
Vec3 enu_position_to_ned(const Vec3& enu_m, double home_altitude_m) {
  return enu_to_ned(Vec3(enu_m.x(), enu_m.y(), enu_m.z() - home_altitude_m));
}
Vec3 ned_position_to_enu(const Vec3& ned_m, double home_altitude_m) {
  const Vec3 p = ned_to_enu(ned_m);
  return {p.x(), p.y(), p.z() + home_altitude_m};
}
double enu_heading_to_ned_yaw(double heading_enu_rad) {
  return wrap_angle(0.5 * kPi - heading_enu_rad);
}
double ned_yaw_to_enu_heading(double yaw_ned_rad) { return wrap_angle(0.5 * kPi - yaw_ned_rad); }

StateReport report_state(const vehicle::State& s, const Vec3& wind_enu_m_s,
                         std::uint32_t time_boot_ms, double home_altitude_m) {
  using namespace vehicle;
  const double psi = s[kPsi];
  const Vec3 ground_velocity_enu(s[kV] * std::cos(psi) + wind_enu_m_s.x(),
                                 s[kV] * std::sin(psi) + wind_enu_m_s.y(),
                                 s[kW] + wind_enu_m_s.z());
  const Vec3 p = enu_position_to_ned(Vec3(s[kX], s[kY], s[kZ]), home_altitude_m);
  const Vec3 v = enu_to_ned(ground_velocity_enu);
  StateReport r;
  r.position.time_boot_ms = time_boot_ms;
  r.position.x = static_cast<float>(p.x());
  r.position.y = static_cast<float>(p.y());
  r.position.z = static_cast<float>(p.z());
  r.position.vx = static_cast<float>(v.x());
  r.position.vy = static_cast<float>(v.y());
  r.position.vz = static_cast<float>(v.z());
  r.attitude.time_boot_ms = time_boot_ms;
  r.attitude.roll = 0.0f;
  r.attitude.pitch = static_cast<float>(pitch_angle_rad(s));
  r.attitude.yaw = static_cast<float>(enu_heading_to_ned_yaw(psi));
  r.attitude.yawspeed = static_cast<float>(-s[kOmega]);
  return r;
}

vehicle::State state_from_report(const LocalPositionNed& position, const Attitude& attitude,
                                 double home_altitude_m) {
  using namespace vehicle;
  const Vec3 p = ned_position_to_enu(Vec3(position.x, position.y, position.z), home_altitude_m);
  const Vec3 v = ned_to_enu(Vec3(position.vx, position.vy, position.vz));
  State s;
  s[kX] = p.x();
  s[kY] = p.y();
  s[kZ] = p.z();
  s[kPsi] = ned_yaw_to_enu_heading(attitude.yaw);
  s[kV] = std::hypot(v.x(), v.y());
  s[kOmega] = -static_cast<double>(attitude.yawspeed);
  s[kW] = v.z();
  return s;
}

SetPositionTargetLocalNed velocity_setpoint(const vehicle::Input& u, double heading_enu_rad,
                                            std::uint32_t time_boot_ms,
                                            std::uint8_t target_system,
                                            std::uint8_t target_component) {
  using namespace vehicle;
  const Vec3 v_enu(u[kSpeedCmd] * std::cos(heading_enu_rad),
                   u[kSpeedCmd] * std::sin(heading_enu_rad), u[kClimbRateCmd]);
  const Vec3 v = enu_to_ned(v_enu);
  SetPositionTargetLocalNed sp;
  sp.time_boot_ms = time_boot_ms;
  sp.target_system = target_system;
  sp.target_component = target_component;
  sp.coordinate_frame = kMavFrameLocalNed;
  sp.type_mask = kTypeMaskVelocityYawRate;
  sp.vx = static_cast<float>(v.x());
  sp.vy = static_cast<float>(v.y());
  sp.vz = static_cast<float>(v.z());
  sp.yaw_rate = static_cast<float>(-u[kTurnRateCmd]);
  return sp;
}

SetPositionTargetLocalNed hold_setpoint(const Vec3& position_enu_m, double home_altitude_m,
                                        std::uint32_t time_boot_ms, std::uint8_t target_system,
                                        std::uint8_t target_component) {
  const Vec3 p = enu_position_to_ned(position_enu_m, home_altitude_m);
  SetPositionTargetLocalNed sp;
  sp.time_boot_ms = time_boot_ms;
  sp.target_system = target_system;
  sp.target_component = target_component;
  sp.coordinate_frame = kMavFrameLocalNed;
  sp.type_mask = kTypeMaskPositionHold;
  sp.x = static_cast<float>(p.x());
  sp.y = static_cast<float>(p.y());
  sp.z = static_cast<float>(p.z());
  return sp;
}

SetpointCommand command_from_setpoint(const SetPositionTargetLocalNed& sp,
                                      double home_altitude_m) {
  if (sp.coordinate_frame != kMavFrameLocalNed)
    return {std::nullopt, std::nullopt,
            fmt::format("coordinate_frame: {} is not MAV_FRAME_LOCAL_NED (1)",
                        sp.coordinate_frame)};
  constexpr std::uint16_t kVelocity = kIgnoreVx | kIgnoreVy | kIgnoreVz;
  constexpr std::uint16_t kUnsupported =
      kIgnoreX | kIgnoreY | kIgnoreZ | kIgnoreAx | kIgnoreAy | kIgnoreAz;
  if ((sp.type_mask & ~kForceIsSet) == kTypeMaskPositionHold) {
    const std::pair<const char*, float> position[] = {{"x", sp.x}, {"y", sp.y}, {"z", sp.z}};
    for (const auto& [name, value] : position)
      if (!std::isfinite(value))
        return {std::nullopt, std::nullopt, fmt::format("{}: {} is not finite", name, value)};
    return {std::nullopt, ned_position_to_enu(Vec3(sp.x, sp.y, sp.z), home_altitude_m), {}};
  }
  if ((sp.type_mask & kVelocity) != 0)
    return {std::nullopt, std::nullopt,
            fmt::format("type_mask: {:#06x} ignores part of the velocity; this "
                        "vehicle flies velocity + yaw rate setpoints only",
                        sp.type_mask)};
  if ((sp.type_mask & kIgnoreYawRate) != 0)
    return {std::nullopt, std::nullopt,
            fmt::format("type_mask: {:#06x} ignores the yaw rate; this vehicle needs it",
                        sp.type_mask)};
  if ((sp.type_mask & kUnsupported) != kUnsupported)
    return {std::nullopt, std::nullopt,
            fmt::format("type_mask: {:#06x} asks for position or acceleration control, which "
                        "this vehicle does not do (set bits 0-2 and 6-8)",
                        sp.type_mask)};
  const std::pair<const char*, float> values[] = {
      {"vx", sp.vx}, {"vy", sp.vy}, {"vz", sp.vz}, {"yaw_rate", sp.yaw_rate}};
  for (const auto& [name, value] : values)
    if (!std::isfinite(value))
      return {std::nullopt, std::nullopt, fmt::format("{}: {} is not finite", name, value)};
  vehicle::Input u;
  u[vehicle::kSpeedCmd] = std::hypot(static_cast<double>(sp.vx), static_cast<double>(sp.vy));
  u[vehicle::kTurnRateCmd] = -static_cast<double>(sp.yaw_rate);
  u[vehicle::kClimbRateCmd] = -static_cast<double>(sp.vz);
  return {u, std::nullopt, {}};
}

}  // namespace ridgeline::mavlink
