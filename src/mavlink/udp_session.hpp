// The wall-clock loops of `ridgeline vehicle-sim` and `ridgeline fly`: a SimulatedVehicle or
// an OffboardPilot behind a UdpLink, ticking at its period, every datagram through a
// StreamParser (so garbage and frames it does not know are counted, not fatal).
#pragma once

#include <atomic>
#include <functional>
#include <string>

#include "mavlink/offboard_pilot.hpp"
#include "mavlink/simulated_vehicle.hpp"
#include "mavlink/stream_parser.hpp"
#include "mavlink/udp_link.hpp"

namespace ridgeline::mavlink {

struct SessionReport {
  ParserStats parser;
  std::uint64_t frames_sent = 0;
  std::uint64_t messages_ignored = 0;  ///< valid frames of a known id this side does not use
  double wall_time_s = 0.0;
};

/// Serves the vehicle until `duration_s` has passed (≤ 0: forever) or `stop` becomes true.
SessionReport serve_vehicle(SimulatedVehicle& vehicle, UdpLink& link, double duration_s,
                            const std::atomic<bool>& stop);

/// Serves the vehicle in lock step (SimulatedVehicle::handle_lockstep, period_s a step):
/// every datagram received is answered with one datagram holding lockstep_reply()'s frames.
/// Until the first datagram arrives, a HEARTBEAT goes to the link's peer (set_peer) every
/// 0.5 s, so a companion listening there learns where the vehicle is. Runs until duration_s
/// of wall time has passed (≤ 0: forever) or `stop` becomes true.
SessionReport serve_vehicle_lockstep(SimulatedVehicle& vehicle, UdpLink& link, double period_s,
                                     double duration_s, const std::atomic<bool>& stop);

/// Flies until the pilot is done. Throws std::runtime_error when the vehicle does not reach
/// offboard within `start_timeout_s` (the reason names the phase it was stuck in).
SessionReport fly_pilot(OffboardPilot& pilot, UdpLink& link, double control_period_s,
                        double start_timeout_s, const std::atomic<bool>& stop);

}  // namespace ridgeline::mavlink
