#include "px4/px4_pilot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <variant>
#include <vector>

#include "core/error.hpp"
#include "px4/px4_frame.hpp"
#include "px4/px4_vehicle.hpp"
#include "transport_dds/topics.hpp"

namespace ridgeline::px4 {
namespace {

using Clock = std::chrono::steady_clock;

/// In flight, odometry missing this long ends the flight: PX4 gives up on a companion whose
/// offboard stream stops for its COM_OF_LOSS_T (default 1 s); the companion gives up on a
/// vehicle the same way, instead of steering on a stale state.
constexpr double kOdometryLossS = 1.0;

template <class M>
std::string topic_of(const transport_dds::Px4Link& link) {
  return transport_dds::px4_topic_name(transport_dds::Topic<M>::spec.name,
                                       link.vehicle_namespace(0));
}

}  // namespace

Px4PilotReport fly_px4_pilot(mavlink::OffboardPilot& pilot, transport_dds::Px4Link& link,
                             const std::string& name, double control_period_s,
                             double start_timeout_s, const std::atomic<bool>& stop) {
  const Clock::time_point start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  Px4PilotReport report;
  std::vector<transport_dds::Px4Received> received;
  std::vector<mavlink::Message> out;
  bool have_state = false, armed = false;
  double next_tick = 0.0;
  double last_state_s = 0.0;  // when usable odometry last arrived
  while (!stop.load() && !pilot.done()) {
    for (double wait = next_tick - elapsed(); wait > 0.0; wait = next_tick - elapsed()) {
      if (!link.wait(wait)) continue;
      received.clear();
      link.take(received);
      for (const transport_dds::Px4Received& r : received) {
        const double now = elapsed();
        const auto ms = static_cast<std::uint32_t>(std::llround(now * 1e3));
        if (const auto* o = std::get_if<msg::VehicleOdometry>(&r.message)) {
          ++report.odometry_received;
          const StateFromPx4 s = state_report_from_px4(*o, ms);
          if (!s.report) {
            ++report.odometry_rejected;
            report.last_rejection =
                fmt::format("{}: {}", topic_of<msg::VehicleOdometry>(link), s.error);
            continue;
          }
          have_state = true;
          last_state_s = now;
          pilot.handle(s.report->position, now);
          pilot.handle(s.report->attitude, now);
        } else if (const auto* st = std::get_if<msg::VehicleStatus>(&r.message)) {
          ++report.status_received;
          armed = status_armed(*st);
          pilot.handle(heartbeat_from_px4(*st), now);
        }
      }
    }
    const double now = elapsed();
    if (pilot.phase() != mavlink::PilotPhase::kFlying && now > start_timeout_s) {
      const std::string odometry = topic_of<msg::VehicleOdometry>(link);
      const std::string status = topic_of<msg::VehicleStatus>(link);
      const std::string waited =
          !have_state
              ? fmt::format("{}: no usable odometry ({} received, {} rejected{})", odometry,
                            report.odometry_received, report.odometry_rejected,
                            report.last_rejection.empty() ? ""
                                                          : "; last: " + report.last_rejection)
          : report.status_received == 0 ? fmt::format("{}: no status", status)
          : !armed ? fmt::format("{}: never armed ({} received)", status, report.status_received)
                   : fmt::format("{}: never in offboard ({} received)", status,
                                 report.status_received);
      throw InputError(name, fmt::format("the PX4 vehicle did not start an offboard flight "
                                         "within {:g} s (stuck {}); waited for {}",
                                         start_timeout_s, mavlink::to_string(pilot.phase()),
                                         waited));
    }
    if (pilot.phase() == mavlink::PilotPhase::kFlying && now - last_state_s > kOdometryLossS)
      throw InputError(
          name, fmt::format("{}: no usable odometry for {:.1f} s in flight ({:.1f} s after the "
                            "start; {} received, {} rejected{}): the vehicle stopped reporting",
                            topic_of<msg::VehicleOdometry>(link), now - last_state_s, now,
                            report.odometry_received, report.odometry_rejected,
                            report.last_rejection.empty() ? ""
                                                          : "; last: " + report.last_rejection));
    out.clear();
    pilot.tick(now, out);
    if (pilot.done()) break;
    const std::uint64_t stamp = system_clock_us();
    // The offboard stream goes out every period, before the vehicle is known and in flight.
    link.publish(0, offboard_control_mode(false, stamp));
    ++report.samples_sent;
    for (const mavlink::Message& m : out) {
      if (const auto* sp = std::get_if<mavlink::SetPositionTargetLocalNed>(&m)) {
        link.publish(0, trajectory_setpoint(*sp, stamp));
        ++report.samples_sent;
      } else if (const auto* c = std::get_if<mavlink::CommandLong>(&m)) {
        link.publish(0, vehicle_command(*c, stamp));
        ++report.samples_sent;
      }
    }
    next_tick = std::max(next_tick + control_period_s, elapsed());
  }
  report.wall_time_s = elapsed();
  return report;
}

}  // namespace ridgeline::px4
