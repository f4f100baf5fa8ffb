// How agents exchange messages. The swarm's only channel: an agent publishes a Message and
// receives what the others published, after the link's latency, possibly reordered or lost.
// The in-process implementation below models the link; a DDS implementation sits behind the
// same interface so the agents run unchanged as separate processes.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "swarm/messages.hpp"

namespace ridgeline::swarm {

/// Counters of one transport.
struct TransportStats {
  std::uint64_t published = 0;  ///< publish() calls
  std::uint64_t sent = 0;       ///< copies addressed to receivers (broadcast fan-out)
  std::uint64_t dropped = 0;    ///< copies lost on the link
  std::uint64_t delivered = 0;  ///< copies handed to receivers
  std::uint64_t rejected = 0;   ///< received copies that failed check_message (DDS transport)
};

class Transport {
 public:
  virtual ~Transport() = default;
  /// Broadcasts `message` from participant `sender` at time now_s to every other participant.
  /// The receivers share the one immutable copy.
  virtual void publish(int sender, double now_s, std::shared_ptr<const Message> message) = 0;
  /// The same for a message the caller keeps: it is copied once.
  void publish(int sender, double now_s, const Message& message) {
    publish(sender, now_s, std::make_shared<const Message>(message));
  }
  /// Appends to `out` every message for `receiver` whose delivery time is ≤ now_s, in
  /// delivery order (which may differ from the order of sending).
  virtual void receive(int receiver, double now_s, std::vector<Envelope>& out) = 0;
  virtual TransportStats stats() const = 0;
};

/// A link's imperfections. Latency of one copy = latency_s + U(0, jitter_s); a jitter larger
/// than the publishing interval reorders messages.
struct LinkModel {
  double latency_s = 0.0;
  double jitter_s = 0.0;
  double drop_rate = 0.0;  ///< probability that one copy is lost, in [0, 1]
};

}  // namespace ridgeline::swarm
