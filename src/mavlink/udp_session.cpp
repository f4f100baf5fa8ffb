#include "mavlink/udp_session.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include <fmt/format.h>

namespace ridgeline::mavlink {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Receives until `deadline_s` (seconds since start), handing each decoded message to `on`.
template <class OnMessage>
void receive_until(UdpLink& link, StreamParser& parser, Clock::time_point start,
                   double deadline_s, SessionReport& report, OnMessage&& on) {
  for (;;) {
    const double wait = deadline_s - seconds_since(start);
    if (wait <= 0.0) return;
    const std::vector<std::uint8_t> datagram = link.receive(wait);
    if (datagram.empty()) continue;
    parser.push(datagram, [&](const Frame& frame) {
      const std::optional<Message> m = decode_message(frame);
      if (m) on(*m, seconds_since(start));
      else ++report.messages_ignored;
    });
  }
}

void send_all(UdpLink& link, std::vector<EncodedFrame>& frames, SessionReport& report) {
  for (const EncodedFrame& f : frames)
    if (link.send(f.view())) ++report.frames_sent;
  frames.clear();
}

}  // namespace

SessionReport serve_vehicle(SimulatedVehicle& vehicle, UdpLink& link, double duration_s,
                            const std::atomic<bool>& stop) {
  SessionReport report;
  StreamParser parser;
  std::vector<EncodedFrame> out;
  const Clock::time_point start = Clock::now();
  const double period = 0.02;
  double next_tick = 0.0;
  while (!stop.load() && (duration_s <= 0.0 || seconds_since(start) < duration_s)) {
    receive_until(link, parser, start, next_tick, report,
                  [&](const Message& m, double t) { vehicle.handle(m, t); });
    vehicle.advance(seconds_since(start), out);
    send_all(link, out, report);
    // A late tick is not made up for with a burst of ticks: the schedule moves on.
    next_tick = std::max(next_tick + period, seconds_since(start));
  }
  report.parser = parser.stats();
  report.wall_time_s = seconds_since(start);
  return report;
}

SessionReport serve_vehicle_lockstep(SimulatedVehicle& vehicle, UdpLink& link, double period_s,
                                     double duration_s, const std::atomic<bool>& stop) {
  SessionReport report;
  StreamParser parser;
  std::vector<EncodedFrame> out;
  std::vector<std::uint8_t> datagram;
  const Clock::time_point start = Clock::now();
  constexpr double kAnnouncePeriodS = 0.5;
  bool heard = false;
  double next_announce = 0.0;
  while (!stop.load() && (duration_s <= 0.0 || seconds_since(start) < duration_s)) {
    if (!heard && seconds_since(start) >= next_announce && link.has_peer()) {
      std::vector<EncodedFrame> hello;
      vehicle.lockstep_reply(hello);  // its heartbeat and where it is
      send_all(link, hello, report);
      next_announce = seconds_since(start) + kAnnouncePeriodS;
    }
    // Short waits keep `stop` and the duration responsive; lock step never waits on a clock.
    const std::vector<std::uint8_t> in = link.receive(0.1);
    if (in.empty()) continue;
    heard = true;
    parser.push(in, [&](const Frame& frame) {
      const std::optional<Message> m = decode_message(frame);
      if (m) vehicle.handle_lockstep(*m, period_s);
      else ++report.messages_ignored;
    });
    vehicle.lockstep_reply(out);
    datagram.clear();
    for (const EncodedFrame& f : out) {
      const std::span<const std::uint8_t> b = f.view();
      datagram.insert(datagram.end(), b.begin(), b.end());
    }
    if (link.send(datagram)) report.frames_sent += out.size();
    out.clear();
  }
  report.parser = parser.stats();
  report.wall_time_s = seconds_since(start);
  return report;
}

SessionReport fly_pilot(OffboardPilot& pilot, UdpLink& link, double control_period_s,
                        double start_timeout_s, const std::atomic<bool>& stop) {
  SessionReport report;
  StreamParser parser;
  std::vector<EncodedFrame> out;
  const Clock::time_point start = Clock::now();
  double next_tick = 0.0;
  while (!stop.load() && !pilot.done()) {
    receive_until(link, parser, start, next_tick, report,
                  [&](const Message& m, double t) { pilot.handle(m, t); });
    const double now = seconds_since(start);
    if (pilot.phase() != PilotPhase::kFlying && now > start_timeout_s)
      throw std::runtime_error(fmt::format(
          "the vehicle did not start an offboard flight within {:.0f} s (stuck {}; {} frames "
          "received, {} rejected)",
          start_timeout_s, to_string(pilot.phase()), parser.stats().accepted(),
          parser.stats().rejected()));
    pilot.tick(now, out);
    send_all(link, out, report);
    next_tick = std::max(next_tick + control_period_s, seconds_since(start));
  }
  report.parser = parser.stats();
  report.wall_time_s = seconds_since(start);
  return report;
}

}  // namespace ridgeline::mavlink
