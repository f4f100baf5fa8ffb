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

/// The pilot's end of vehicle 0 of a companion-side Px4Link: what comes in goes to the pilot as
/// the MAVLink messages it stands for, what the pilot sends goes out as px4_msgs.
class PilotWire {
 public:
  PilotWire(mavlink::OffboardPilot& pilot, transport_dds::Px4Link& link)
      : pilot_(pilot),
        link_(link),
        odometry_topic_(topic_of<msg::VehicleOdometry>()),
        status_topic_(topic_of<msg::VehicleStatus>()) {}

  /// Hands everything received until `deadline_s` (on the clock `now`) to the pilot.
  template <class Now>
  void receive_until(double deadline_s, Now&& now) {
    for (double wait = deadline_s - now(); wait > 0.0; wait = deadline_s - now()) {
      if (!link_.wait(wait)) continue;
      received_.clear();
      link_.take(received_);
      for (const transport_dds::Px4Received& r : received_) apply(r, now());
    }
  }

  /// One period's samples: the offboard stream (always, before the vehicle is known and in
  /// flight), then the pilot's setpoint and commands; its HEARTBEAT has no DDS counterpart.
  void send(const std::vector<mavlink::Message>& messages, std::uint64_t stamp) {
    link_.publish(0, offboard_control_mode(false, stamp));
    ++report_.samples_sent;
    for (const mavlink::Message& m : messages) {
      if (const auto* sp = std::get_if<mavlink::SetPositionTargetLocalNed>(&m)) {
        link_.publish(0, trajectory_setpoint(*sp, stamp));
        ++report_.samples_sent;
      } else if (const auto* c = std::get_if<mavlink::CommandLong>(&m)) {
        link_.publish(0, vehicle_command(*c, stamp));
        ++report_.samples_sent;
      }
    }
  }

  /// What the start is still waiting for: the topic and what has (not) come on it.
  std::string start_awaited() const {
    if (!have_state_)
      return fmt::format("{}: no usable odometry ({} received, {} rejected{})", odometry_topic_,
                         report_.odometry_received, report_.odometry_rejected, last_rejection());
    if (report_.status_received == 0) return fmt::format("{}: no status", status_topic_);
    return fmt::format("{}: never {} ({} received)", status_topic_,
                       armed_ ? "in offboard" : "armed", report_.status_received);
  }

  /// Why the flight cannot go on at `now_s`, or "" while odometry keeps coming.
  std::string in_flight_loss(double now_s) const {
    if (now_s - last_state_s_ <= kOdometryLossS) return "";
    return fmt::format(
        "{}: no usable odometry for {:.1f} s in flight ({:.1f} s after the start; "
        "{} received, {} rejected{}): the vehicle stopped reporting",
        odometry_topic_, now_s - last_state_s_, now_s, report_.odometry_received,
        report_.odometry_rejected, last_rejection());
  }

  Px4PilotReport& report() { return report_; }

 private:
  template <class M>
  std::string topic_of() const {
    return transport_dds::px4_topic_name(transport_dds::Topic<M>::spec.name,
                                         link_.vehicle_namespace(0));
  }
  std::string last_rejection() const {
    return report_.last_rejection.empty() ? "" : "; last: " + report_.last_rejection;
  }

  void apply(const transport_dds::Px4Received& r, double now_s) {
    if (const auto* o = std::get_if<msg::VehicleOdometry>(&r.message)) {
      ++report_.odometry_received;
      const StateFromPx4 s =
          state_report_from_px4(*o, static_cast<std::uint32_t>(std::llround(now_s * 1e3)));
      if (!s.report) {
        ++report_.odometry_rejected;
        report_.last_rejection = fmt::format("{}: {}", odometry_topic_, s.error);
        return;
      }
      have_state_ = true;
      last_state_s_ = now_s;
      pilot_.handle(s.report->position, now_s);
      pilot_.handle(s.report->attitude, now_s);
    } else if (const auto* st = std::get_if<msg::VehicleStatus>(&r.message)) {
      ++report_.status_received;
      armed_ = status_armed(*st);
      pilot_.handle(heartbeat_from_px4(*st), now_s);
    }
  }

  mavlink::OffboardPilot& pilot_;
  transport_dds::Px4Link& link_;
  std::string odometry_topic_, status_topic_;
  std::vector<transport_dds::Px4Received> received_;
  Px4PilotReport report_;
  bool have_state_ = false, armed_ = false;
  double last_state_s_ = 0.0;  ///< when usable odometry last arrived
};

}  // namespace

Px4PilotReport fly_px4_pilot(mavlink::OffboardPilot& pilot, transport_dds::Px4Link& link,
                             const std::string& name, double control_period_s,
                             double start_timeout_s, const std::atomic<bool>& stop) {
  const Clock::time_point start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  PilotWire wire(pilot, link);
  std::vector<mavlink::Message> out;
  double next_tick = 0.0;
  while (!stop.load() && !pilot.done()) {
    wire.receive_until(next_tick, elapsed);
    const double now = elapsed();
    const bool flying = pilot.phase() == mavlink::PilotPhase::kFlying;
    if (!flying && now > start_timeout_s)
      throw InputError(name, fmt::format("the PX4 vehicle did not start an offboard flight "
                                         "within {:g} s (stuck {}); waited for {}",
                                         start_timeout_s, mavlink::to_string(pilot.phase()),
                                         wire.start_awaited()));
    if (flying) {
      if (std::string loss = wire.in_flight_loss(now); !loss.empty()) throw InputError(name, loss);
    }
    out.clear();
    pilot.tick(now, out);
    if (pilot.done()) break;
    wire.send(out, system_clock_us());
    // A late tick is not made up for with a burst of ticks: the schedule moves on.
    next_tick = std::max(next_tick + control_period_s, elapsed());
  }
  wire.report().wall_time_s = elapsed();
  return wire.report();
}

}  // namespace ridgeline::px4
