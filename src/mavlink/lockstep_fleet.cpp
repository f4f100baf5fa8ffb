#include "mavlink/lockstep_fleet.hpp"

#include <fmt/format.h>
#include <poll.h>

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "core/error.hpp"
#include "mavlink/messages.hpp"
#include "mavlink/ned_frame.hpp"
#include "mavlink/simulated_vehicle.hpp"

namespace ridgeline::mavlink {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

LockstepFleet::LockstepFleet(const LockstepFleetOptions& options, std::vector<std::string> names,
                             std::vector<UdpLink> links)
    : o_(options) {
  const std::pair<const char*, double> periods[] = {{"period_s", o_.period_s},
                                                    {"start_timeout_s", o_.start_timeout_s},
                                                    {"resend_after_s", o_.resend_after_s},
                                                    {"step_timeout_s", o_.step_timeout_s}};
  for (const auto& [name, value] : periods)
    if (!(value > 0.0) || !std::isfinite(value))
      throw InputError(name, fmt::format("{} must be a positive number of seconds", value));
  // Lock-step stamps are whole milliseconds: consecutive steps must differ.
  if (o_.period_s < 0.002) throw InputError("period_s", "must be at least 2 ms in lock step");
  if (names.size() != links.size())
    throw InputError("links", fmt::format("{} links for {} names", links.size(), names.size()));
  for (std::size_t i = 0; i < links.size(); ++i) {
    vehicles_.emplace_back(names[i], std::move(links[i]));
  }
}

FleetVehicleStats LockstepFleet::stats(int i) const {
  const Vehicle& v = vehicles_[static_cast<std::size_t>(i)];
  FleetVehicleStats s = v.stats;
  s.parser = v.parser.stats();
  return s;
}

void LockstepFleet::send(Vehicle& v, const std::vector<EncodedFrame>& frames) {
  std::vector<std::uint8_t> datagram;
  for (const EncodedFrame& f : frames) {
    const std::span<const std::uint8_t> b = f.view();
    datagram.insert(datagram.end(), b.begin(), b.end());
  }
  // Without a peer yet (a spawned vehicle that has not announced itself) nothing goes out;
  // the round is repeated.
  if (v.link.send(datagram)) {
    ++v.stats.datagrams_sent;
    v.stats.frames_sent += frames.size();
  }
}

void LockstepFleet::receive(double timeout_s) {
  std::vector<pollfd> fds;
  for (const Vehicle& v : vehicles_) fds.push_back({v.link.native_handle(), POLLIN, 0});
  const int timeout_ms = static_cast<int>(std::ceil(std::max(0.0, timeout_s) * 1000.0));
  if (::poll(fds.data(), fds.size(), timeout_ms) <= 0) return;
  for (std::size_t i = 0; i < vehicles_.size(); ++i) {
    if ((fds[i].revents & POLLIN) == 0) continue;
    Vehicle& v = vehicles_[i];
    // Everything queued on this link, without waiting.
    for (;;) {
      const std::vector<std::uint8_t> datagram = v.link.receive(0.0);
      if (datagram.empty()) break;
      v.parser.push(datagram, [&](const Frame& frame) {
        const std::optional<Message> m = decode_message(frame);
        if (!m) return;
        if (const auto* p = std::get_if<LocalPositionNed>(&*m)) {
          v.have_position = true;
          v.position_ms = p->time_boot_ms;
          v.report.position_m = ned_position_to_enu(Vec3(p->x, p->y, p->z), o_.home_altitude_m);
          v.report.ground_velocity_m_s = ned_to_enu(Vec3(p->vx, p->vy, p->vz));
        } else if (const auto* a = std::get_if<Attitude>(&*m)) {
          v.have_attitude = true;
          v.attitude_ms = a->time_boot_ms;
          v.report.heading_rad = ned_yaw_to_enu_heading(a->yaw);
          v.report.turn_rate_rad_s = -static_cast<double>(a->yawspeed);
        } else if (const auto* h = std::get_if<Heartbeat>(&*m)) {
          v.have_heartbeat = true;
          v.armed = (h->base_mode & kModeFlagSafetyArmed) != 0;
          v.offboard = (h->base_mode & kModeFlagCustomModeEnabled) != 0 &&
                       ((h->custom_mode >> 16) & 0xFF) == kPx4MainModeOffboard;
        }
      });
    }
  }
}

void LockstepFleet::start(std::vector<FleetReport>& out) {
  const Clock::time_point start = Clock::now();
  std::vector<double> next_round(vehicles_.size(), 0.0);
  auto ready = [](const Vehicle& v) {
    return v.have_position && v.have_attitude && v.position_ms == 0 && v.attitude_ms == 0 &&
           v.armed && v.offboard;
  };
  for (;;) {
    bool all_ready = true;
    for (std::size_t i = 0; i < vehicles_.size(); ++i) {
      Vehicle& v = vehicles_[i];
      if (ready(v)) continue;
      all_ready = false;
      const double now = seconds_since(start);
      if (now > o_.start_timeout_s) {
        const char* phase = !v.link.has_peer()                      ? "no announcement from it"
                            : !(v.have_position && v.have_attitude) ? "no state reported"
                            : !v.armed                              ? "not armed"
                            : !v.offboard                           ? "not in offboard"
                                                                    : "its clock is not at 0";
        throw std::runtime_error(fmt::format(
            "{}: the MAVLink vehicle at {} did not start a lock-step offboard flight within "
            "{:g} s ({}; {} frames received, {} rejected)",
            v.name, v.link.peer_text(), o_.start_timeout_s, phase, v.parser.stats().accepted(),
            v.parser.stats().rejected()));
      }
      if (now < next_round[i]) continue;
      std::vector<EncodedFrame> frames;
      Heartbeat h;
      h.type = kMavTypeOnboardController;
      h.autopilot = kMavAutopilotInvalid;
      h.system_status = kMavStateActive;
      frames.push_back(encode_message(h, {v.sequence++, o_.system_id, o_.component_id, 0}));
      if (v.have_position) {
        frames.push_back(encode_message(hold_setpoint(v.report.position_m, o_.home_altitude_m,
                                                      SimulatedVehicle::kKeepAliveStamp, 1, 1),
                                        {v.sequence++, o_.system_id, o_.component_id, 0}));
        CommandLong c;
        c.target_system = 1;
        c.target_component = 1;
        if (!v.armed) {
          c.command = kMavCmdComponentArmDisarm;
          c.param1 = 1.0f;
          frames.push_back(encode_message(c, {v.sequence++, o_.system_id, o_.component_id, 0}));
        } else if (!v.offboard) {
          c.command = kMavCmdDoSetMode;
          c.param1 = static_cast<float>(kModeFlagCustomModeEnabled);
          c.param2 = static_cast<float>(kPx4MainModeOffboard);
          frames.push_back(encode_message(c, {v.sequence++, o_.system_id, o_.component_id, 0}));
        }
      }
      send(v, frames);
      next_round[i] = now + o_.resend_after_s;
    }
    if (all_ready) break;
    // An answer starts the next round at once (the vehicle answers every datagram).
    const std::vector<std::uint64_t> before = [&] {
      std::vector<std::uint64_t> b;
      for (const Vehicle& v : vehicles_) b.push_back(v.parser.stats().accepted());
      return b;
    }();
    receive(o_.resend_after_s);
    for (std::size_t i = 0; i < vehicles_.size(); ++i)
      if (vehicles_[i].parser.stats().accepted() != before[i]) next_round[i] = 0.0;
  }
  out.clear();
  for (Vehicle& v : vehicles_) {
    v.stats.start_s = seconds_since(start);
    out.push_back(v.report);
  }
}

void LockstepFleet::step(std::uint64_t k, const std::vector<FleetCommand>& commands,
                         std::vector<FleetReport>& out) {
  if (commands.size() != vehicles_.size())
    throw InputError("commands",
                     fmt::format("{} commands for {} vehicles", commands.size(), vehicles_.size()));
  const std::uint32_t stamp = SimulatedVehicle::lockstep_stamp_ms(k, o_.period_s);
  const std::uint32_t answer = SimulatedVehicle::lockstep_stamp_ms(k + 1, o_.period_s);
  const Clock::time_point start = Clock::now();
  std::vector<std::vector<EncodedFrame>> datagrams(vehicles_.size());
  std::vector<double> next_send(vehicles_.size(), 0.0);
  std::vector<bool> done(vehicles_.size(), false);
  for (std::size_t i = 0; i < vehicles_.size(); ++i) {
    Vehicle& v = vehicles_[i];
    const FleetCommand& c = commands[i];
    const SetPositionTargetLocalNed sp =
        c.hold ? hold_setpoint(v.report.position_m, o_.home_altitude_m, stamp, 1, 1)
               : velocity_setpoint(c.command, v.report.heading_rad, stamp, 1, 1);
    datagrams[i].push_back(encode_message(sp, {v.sequence++, o_.system_id, o_.component_id, 0}));
  }
  for (;;) {
    bool all_done = true;
    for (std::size_t i = 0; i < vehicles_.size(); ++i) {
      Vehicle& v = vehicles_[i];
      if (done[i]) continue;
      if (v.have_position && v.have_attitude && v.position_ms == answer &&
          v.attitude_ms == answer) {
        done[i] = true;
        ++v.stats.steps;
        v.stats.round_trip_us.push_back(seconds_since(start) * 1e6);
        if (!v.armed || !v.offboard)
          throw std::runtime_error(fmt::format(
              "{}: the MAVLink vehicle at {} left the offboard flight at step {} (t = {:.2f} s): "
              "{}",
              v.name, v.link.peer_text(), k + 1, static_cast<double>(k + 1) * o_.period_s,
              v.armed ? "not in offboard" : "disarmed"));
        continue;
      }
      all_done = false;
      const double now = seconds_since(start);
      if (now > o_.step_timeout_s)
        throw std::runtime_error(fmt::format(
            "{}: the MAVLink vehicle at {} did not answer step {} (t = {:.2f} s) within {:g} s "
            "({} resends; {} frames received, {} rejected)",
            v.name, v.link.peer_text(), k, static_cast<double>(k) * o_.period_s, o_.step_timeout_s,
            v.stats.resends, v.parser.stats().accepted(), v.parser.stats().rejected()));
      if (now >= next_send[i]) {
        if (next_send[i] > 0.0) ++v.stats.resends;
        send(v, datagrams[i]);
        next_send[i] = now + o_.resend_after_s;
      }
    }
    if (all_done) break;
    const std::vector<std::uint32_t> before = [&] {
      std::vector<std::uint32_t> b;
      for (const Vehicle& v : vehicles_) b.push_back(v.position_ms);
      return b;
    }();
    receive(o_.resend_after_s);
    for (std::size_t i = 0; i < vehicles_.size(); ++i) {
      const Vehicle& v = vehicles_[i];
      if (!done[i] && v.position_ms != before[i] && v.position_ms != answer)
        ++vehicles_[i].stats.stale_reports;
    }
  }
  out.clear();
  for (const Vehicle& v : vehicles_) out.push_back(v.report);
}

}  // namespace ridgeline::mavlink
