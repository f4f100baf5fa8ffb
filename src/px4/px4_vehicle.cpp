#include "px4/px4_vehicle.hpp"

#include <fmt/format.h>

#include <chrono>
#include <variant>
#include <vector>

#include "px4/px4_frame.hpp"
#include "transport_dds/topics.hpp"

namespace ridgeline::px4 {

Px4VehicleStats serve_px4_vehicle_lockstep(mavlink::SimulatedVehicle& vehicle,
                                           transport_dds::Px4Link& link, double period_s,
                                           double duration_s, const std::atomic<bool>& stop) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  Px4VehicleStats stats;
  // Lock-step time of the latest offboard_control_mode (−∞: none yet). The stream counts as
  // alive for the vehicle's setpoint timeout (PX4's offboard loss timeout).
  double last_mode_s = -1e300;
  const std::string& ns = link.vehicle_namespace(0);
  const std::string setpoint_topic =
      transport_dds::px4_topic_name(transport_dds::Topic<msg::TrajectorySetpoint>::spec.name, ns);
  const std::string command_topic =
      transport_dds::px4_topic_name(transport_dds::Topic<msg::VehicleCommand>::spec.name, ns);
  std::vector<transport_dds::Px4Received> received;
  while (!stop.load() && (duration_s <= 0.0 || elapsed() < duration_s)) {
    if (!link.wait(0.1)) continue;
    received.clear();
    link.take(received);
    if (received.empty()) continue;
    for (const transport_dds::Px4Received& r : received) {
      if (std::holds_alternative<msg::OffboardControlMode>(r.message)) {
        ++stats.offboard_control_modes;
        last_mode_s = vehicle.time_s();
      } else if (const auto* t = std::get_if<msg::TrajectorySetpoint>(&r.message)) {
        ++stats.setpoints;
        const SetpointFromPx4 sp = setpoint_from_px4(*t);
        if (!sp.setpoint) {
          ++stats.setpoints_rejected;
          stats.last_rejection = fmt::format("{}: {}", setpoint_topic, sp.error);
          continue;
        }
        vehicle.handle_lockstep(mavlink::Message(*sp.setpoint), period_s);
      } else if (const auto* c = std::get_if<msg::VehicleCommand>(&r.message)) {
        ++stats.commands;
        const bool stream_alive = vehicle.time_s() - last_mode_s <= vehicle.setpoint_timeout_s();
        if (c->command == msg::VehicleCommand::kDoSetMode && !stream_alive) {
          ++stats.commands_refused;
          stats.last_rejection =
              fmt::format("{}: offboard refused: no offboard_control_mode within {:g} s",
                          command_topic, vehicle.setpoint_timeout_s());
          continue;
        }
        vehicle.handle_lockstep(mavlink::Message(command_long(*c)), period_s);
      }
    }
    const mavlink::StateReport report = vehicle.lockstep_state_report();
    const std::uint64_t stamp = stamp_us(report.position.time_boot_ms);
    link.publish(0, vehicle_status(vehicle.armed(), vehicle.offboard(), stamp));
    link.publish(0, odometry(report, stamp));
    ++stats.replies;
  }
  stats.wall_time_s = elapsed();
  return stats;
}

}  // namespace ridgeline::px4
