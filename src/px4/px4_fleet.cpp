#include "px4/px4_fleet.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "core/error.hpp"
#include "mavlink/ned_frame.hpp"
#include "mavlink/simulated_vehicle.hpp"
#include "px4/px4_frame.hpp"
#include "transport_dds/topics.hpp"

namespace ridgeline::px4 {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

template <class M>
const char* topic_of() {
  return transport_dds::Topic<M>::spec.name;
}

}  // namespace

Px4Fleet::Px4Fleet(const Px4FleetOptions& options, std::vector<std::string> names,
                   std::unique_ptr<transport_dds::Px4Link> link)
    : o_(options), link_(std::move(link)) {
  const std::pair<const char*, double> periods[] = {{"period_s", o_.period_s},
                                                    {"start_timeout_s", o_.start_timeout_s},
                                                    {"resend_after_s", o_.resend_after_s},
                                                    {"step_timeout_s", o_.step_timeout_s}};
  for (const auto& [name, value] : periods)
    if (!(value > 0.0) || !std::isfinite(value))
      throw InputError(name, fmt::format("{} must be a positive number of seconds", value));
  if (o_.period_s < 0.002) throw InputError("period_s", "must be at least 2 ms in lock step");
  if (link_ == nullptr || static_cast<int>(names.size()) != link_->size())
    throw InputError("names", fmt::format("{} names for {} vehicles", names.size(),
                                          link_ == nullptr ? 0 : link_->size()));
  for (std::string& name : names) {
    Vehicle v;
    v.name = std::move(name);
    vehicles_.push_back(std::move(v));
  }
}

std::string Px4Fleet::topic(int i, const char* name) const {
  return transport_dds::px4_topic_name(name, link_->vehicle_namespace(i));
}

void Px4Fleet::receive(double timeout_s) {
  if (!link_->wait(timeout_s)) return;
  std::vector<transport_dds::Px4Received> received;
  link_->take(received);
  for (const transport_dds::Px4Received& r : received) {
    Vehicle& v = vehicles_[static_cast<std::size_t>(r.vehicle)];
    if (const auto* o = std::get_if<msg::VehicleOdometry>(&r.message)) {
      ++v.stats.odometry_received;
      const ReportFromPx4 converted = report_from_px4(*o, o_.home_altitude_m);
      if (!converted.report) {
        ++v.stats.rejected;
        v.stats.last_rejection = fmt::format(
            "{}: {}", topic(r.vehicle, topic_of<msg::VehicleOdometry>()), converted.error);
        continue;
      }
      v.have_odometry = true;
      v.odometry_in_offboard = v.armed && v.offboard;
      v.odometry_stamp = o->timestamp;
      v.report = *converted.report;
    } else if (const auto* s = std::get_if<msg::VehicleStatus>(&r.message)) {
      ++v.stats.status_received;
      v.have_status = true;
      v.armed = status_armed(*s);
      v.offboard = status_offboard(*s);
      if (!(v.armed && v.offboard)) v.odometry_in_offboard = false;
    }
  }
}

void Px4Fleet::start(std::vector<mavlink::FleetReport>& out) {
  const Clock::time_point start = Clock::now();
  std::vector<double> next_round(vehicles_.size(), 0.0);
  auto ready = [](const Vehicle& v) {
    return v.have_odometry && v.odometry_stamp == 0 && v.have_status && v.armed && v.offboard &&
           v.odometry_in_offboard;
  };
  for (;;) {
    bool all_ready = true;
    for (std::size_t n = 0; n < vehicles_.size(); ++n) {
      const int i = static_cast<int>(n);
      Vehicle& v = vehicles_[n];
      if (ready(v)) continue;
      all_ready = false;
      const double now = seconds_since(start);
      if (now > o_.start_timeout_s) {
        const std::string waited =
            !v.have_odometry
                ? fmt::format(
                      "{}: no usable odometry ({} received, {} rejected{})",
                      topic(i, topic_of<msg::VehicleOdometry>()), v.stats.odometry_received,
                      v.stats.rejected,
                      v.stats.last_rejection.empty() ? "" : "; last: " + v.stats.last_rejection)
            : !v.have_status
                ? fmt::format("{}: no status", topic(i, topic_of<msg::VehicleStatus>()))
            : !v.armed ? fmt::format("{}: never armed", topic(i, topic_of<msg::VehicleStatus>()))
            : !v.offboard
                ? fmt::format("{}: never in offboard", topic(i, topic_of<msg::VehicleStatus>()))
                : fmt::format("{}: odometry in offboard stamped 0 (its clock is elsewhere)",
                              topic(i, topic_of<msg::VehicleOdometry>()));
        throw InputError(v.name, fmt::format("the PX4 vehicle did not start a lock-step offboard "
                                             "flight within {:g} s; waited for {}",
                                             o_.start_timeout_s, waited));
      }
      if (now < next_round[n]) continue;
      const std::uint64_t keep_alive = kKeepAliveStampUs;
      link_->publish(i, offboard_control_mode(true, keep_alive));
      ++v.stats.samples_sent;
      if (v.have_odometry) {
        const mavlink::SetPositionTargetLocalNed hold =
            mavlink::hold_setpoint(v.report.position_m, o_.home_altitude_m,
                                   mavlink::SimulatedVehicle::kKeepAliveStamp, 1, 1);
        link_->publish(i, trajectory_setpoint(hold, keep_alive));
        ++v.stats.samples_sent;
        if (!v.armed || !v.offboard) {
          link_->publish(i, v.armed ? offboard_command(o_.target_system, keep_alive)
                                    : arm_command(o_.target_system, keep_alive));
          ++v.stats.samples_sent;
        }
      }
      next_round[n] = now + o_.resend_after_s;
    }
    if (all_ready) break;
    std::vector<std::uint64_t> before;
    for (const Vehicle& v : vehicles_) before.push_back(v.stats.odometry_received);
    receive(o_.resend_after_s);
    // An answer starts the vehicle's next round at once (it answers every round).
    for (std::size_t n = 0; n < vehicles_.size(); ++n)
      if (vehicles_[n].stats.odometry_received != before[n]) next_round[n] = 0.0;
  }
  out.clear();
  for (Vehicle& v : vehicles_) {
    v.stats.start_s = seconds_since(start);
    out.push_back(v.report);
  }
}

void Px4Fleet::step(std::uint64_t k, const std::vector<mavlink::FleetCommand>& commands,
                    std::vector<mavlink::FleetReport>& out) {
  if (commands.size() != vehicles_.size())
    throw InputError("commands",
                     fmt::format("{} commands for {} vehicles", commands.size(), vehicles_.size()));
  const std::uint32_t stamp_ms = mavlink::SimulatedVehicle::lockstep_stamp_ms(k, o_.period_s);
  const std::uint64_t stamp = stamp_us(stamp_ms);
  const std::uint64_t answer =
      stamp_us(mavlink::SimulatedVehicle::lockstep_stamp_ms(k + 1, o_.period_s));
  const Clock::time_point start = Clock::now();
  std::vector<msg::TrajectorySetpoint> setpoints;
  for (std::size_t n = 0; n < vehicles_.size(); ++n) {
    const Vehicle& v = vehicles_[n];
    const mavlink::FleetCommand& c = commands[n];
    setpoints.push_back(trajectory_setpoint(
        c.hold ? mavlink::hold_setpoint(v.report.position_m, o_.home_altitude_m, stamp_ms, 1, 1)
               : mavlink::velocity_setpoint(c.command, v.report.heading_rad, stamp_ms, 1, 1),
        stamp));
  }
  std::vector<double> next_send(vehicles_.size(), 0.0);
  std::vector<bool> done(vehicles_.size(), false);
  for (;;) {
    bool all_done = true;
    for (std::size_t n = 0; n < vehicles_.size(); ++n) {
      const int i = static_cast<int>(n);
      Vehicle& v = vehicles_[n];
      if (done[n]) continue;
      if (v.odometry_stamp == answer) {
        done[n] = true;
        ++v.stats.steps;
        v.stats.round_trip_us.push_back(seconds_since(start) * 1e6);
        if (!v.armed || !v.offboard)
          throw InputError(v.name, fmt::format("{}: the PX4 vehicle left the offboard flight at "
                                               "step {} (t = {:.2f} s): {}",
                                               topic(i, topic_of<msg::VehicleStatus>()), k + 1,
                                               static_cast<double>(k + 1) * o_.period_s,
                                               v.armed ? "not in offboard" : "disarmed"));
        continue;
      }
      all_done = false;
      const double now = seconds_since(start);
      if (now > o_.step_timeout_s)
        throw InputError(
            v.name,
            fmt::format("{}: no odometry stamped {} us (the answer to step {}, t = {:.2f} s) "
                        "within {:g} s ({} resends; {} odometry received, {} rejected{})",
                        topic(i, topic_of<msg::VehicleOdometry>()), answer, k,
                        static_cast<double>(k) * o_.period_s, o_.step_timeout_s, v.stats.resends,
                        v.stats.odometry_received, v.stats.rejected,
                        v.stats.last_rejection.empty() ? "" : "; last: " + v.stats.last_rejection));
      if (now >= next_send[n]) {
        if (next_send[n] > 0.0) ++v.stats.resends;
        link_->publish(i, offboard_control_mode(commands[n].hold, stamp));
        link_->publish(i, setpoints[n]);
        v.stats.samples_sent += 2;
        next_send[n] = now + o_.resend_after_s;
      }
    }
    if (all_done) break;
    std::vector<std::uint64_t> before;
    for (const Vehicle& v : vehicles_) before.push_back(v.odometry_stamp);
    receive(o_.resend_after_s);
    for (std::size_t n = 0; n < vehicles_.size(); ++n) {
      const Vehicle& v = vehicles_[n];
      if (!done[n] && v.odometry_stamp != before[n] && v.odometry_stamp != answer)
        ++vehicles_[n].stats.stale_reports;
    }
  }
  out.clear();
  for (const Vehicle& v : vehicles_) out.push_back(v.report);
}

}  // namespace ridgeline::px4
