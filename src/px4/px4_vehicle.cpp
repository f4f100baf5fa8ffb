#include "px4/px4_vehicle.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <variant>
#include <vector>

#include "px4/px4_frame.hpp"
#include "transport_dds/topics.hpp"

namespace ridgeline::px4 {
namespace {

using Clock = std::chrono::steady_clock;

/// What arrives on fmu/in, checked as PX4 checks it and handed to the vehicle as the MAVLink
/// message it stands for (lock step and real time alike).
class Inputs {
 public:
  Inputs(const mavlink::SimulatedVehicle& vehicle, const std::string& ns, Px4VehicleStats& stats)
      : vehicle_(vehicle),
        stats_(stats),
        setpoint_topic_(transport_dds::px4_topic_name(
            transport_dds::Topic<msg::TrajectorySetpoint>::spec.name, ns)),
        command_topic_(transport_dds::px4_topic_name(
            transport_dds::Topic<msg::VehicleCommand>::spec.name, ns)) {}

  /// The MAVLink message `r` stands for, or nothing (a mode sample, a rejected setpoint, a
  /// refused command). now_s: the vehicle's time, for the offboard stream's age.
  std::optional<mavlink::Message> convert(const transport_dds::Px4Received& r, double now_s) {
    if (std::holds_alternative<msg::OffboardControlMode>(r.message)) {
      ++stats_.offboard_control_modes;
      last_mode_s_ = now_s;
    } else if (const auto* t = std::get_if<msg::TrajectorySetpoint>(&r.message)) {
      ++stats_.setpoints;
      const SetpointFromPx4 sp = setpoint_from_px4(*t);
      if (sp.setpoint) return mavlink::Message(*sp.setpoint);
      ++stats_.setpoints_rejected;
      stats_.last_rejection = fmt::format("{}: {}", setpoint_topic_, sp.error);
    } else if (const auto* c = std::get_if<msg::VehicleCommand>(&r.message)) {
      ++stats_.commands;
      const bool stream_alive = now_s - last_mode_s_ <= vehicle_.setpoint_timeout_s();
      if (c->command != msg::VehicleCommand::kDoSetMode || stream_alive)
        return mavlink::Message(command_long(*c));
      ++stats_.commands_refused;
      stats_.last_rejection =
          fmt::format("{}: offboard refused: no offboard_control_mode within {:g} s",
                      command_topic_, vehicle_.setpoint_timeout_s());
    }
    return std::nullopt;
  }

 private:
  const mavlink::SimulatedVehicle& vehicle_;
  Px4VehicleStats& stats_;
  std::string setpoint_topic_, command_topic_;
  /// Vehicle time of the latest offboard_control_mode (−∞: none yet). The stream counts as
  /// alive for the vehicle's setpoint timeout (PX4's offboard loss timeout).
  double last_mode_s_ = -1e300;
};

}  // namespace

std::uint64_t system_clock_us() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                        std::chrono::system_clock::now().time_since_epoch())
                                        .count());
}

Px4VehicleStats serve_px4_vehicle_lockstep(mavlink::SimulatedVehicle& vehicle,
                                           transport_dds::Px4Link& link, double period_s,
                                           double duration_s, const std::atomic<bool>& stop) {
  const Clock::time_point start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  Px4VehicleStats stats;
  Inputs inputs(vehicle, link.vehicle_namespace(0), stats);
  std::vector<transport_dds::Px4Received> received;
  while (!stop.load() && (duration_s <= 0.0 || elapsed() < duration_s)) {
    if (!link.wait(0.1)) continue;
    received.clear();
    link.take(received);
    if (received.empty()) continue;
    for (const transport_dds::Px4Received& r : received)
      if (const auto m = inputs.convert(r, vehicle.time_s())) vehicle.handle_lockstep(*m, period_s);
    const mavlink::StateReport report = vehicle.lockstep_state_report();
    const std::uint64_t stamp = stamp_us(report.position.time_boot_ms);
    link.publish(0, vehicle_status(vehicle.armed(), vehicle.offboard(), stamp));
    link.publish(0, odometry(report, stamp));
    ++stats.replies;
    ++stats.status_sent;
  }
  stats.wall_time_s = elapsed();
  return stats;
}

Px4VehicleStats serve_px4_vehicle(mavlink::SimulatedVehicle& vehicle, transport_dds::Px4Link& link,
                                  double duration_s, const std::atomic<bool>& stop) {
  constexpr double kPeriodS = 0.02;       // odometry at 50 Hz
  constexpr double kStatusPeriodS = 0.5;  // vehicle_status at 2 Hz, and on a change
  const Clock::time_point start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  Px4VehicleStats stats;
  Inputs inputs(vehicle, link.vehicle_namespace(0), stats);
  std::vector<transport_dds::Px4Received> received;
  std::vector<mavlink::Message> out;
  double next_tick = 0.0, next_status = 0.0;
  bool armed = vehicle.armed(), offboard = vehicle.offboard();
  while (!stop.load() && (duration_s <= 0.0 || elapsed() < duration_s)) {
    for (double wait = next_tick - elapsed(); wait > 0.0; wait = next_tick - elapsed()) {
      if (!link.wait(wait)) continue;
      received.clear();
      link.take(received);
      for (const transport_dds::Px4Received& r : received) {
        const double now = elapsed();
        if (const auto m = inputs.convert(r, now)) vehicle.handle(*m, now);
      }
    }
    const double now = elapsed();
    out.clear();
    vehicle.advance(now, out);
    const std::uint64_t stamp = system_clock_us();
    const mavlink::LocalPositionNed* position = nullptr;
    for (const mavlink::Message& m : out) {
      if (const auto* p = std::get_if<mavlink::LocalPositionNed>(&m)) position = p;
      if (const auto* a = std::get_if<mavlink::Attitude>(&m); a != nullptr && position != nullptr) {
        link.publish(0, odometry({*position, *a}, stamp));
        ++stats.replies;
      }
    }
    if (now >= next_status || vehicle.armed() != armed || vehicle.offboard() != offboard) {
      armed = vehicle.armed();
      offboard = vehicle.offboard();
      link.publish(0, vehicle_status(armed, offboard, stamp));
      ++stats.status_sent;
      next_status = now + kStatusPeriodS;
    }
    // A late tick is not made up for with a burst of ticks: the schedule moves on.
    next_tick = std::max(next_tick + kPeriodS, elapsed());
  }
  stats.wall_time_s = elapsed();
  return stats;
}

}  // namespace ridgeline::px4
