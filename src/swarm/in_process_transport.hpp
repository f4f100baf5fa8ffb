// Transport inside one process, for simulation: deterministic for a seed, with the latency,
// jitter (and so reordering) and loss of a LinkModel.
#pragma once

#include <cstdint>
#include <memory>
#include <queue>
#include <vector>

#include "core/random.hpp"
#include "swarm/transport.hpp"

namespace ridgeline::swarm {

class InProcessTransport : public Transport {
 public:
  /// Participants are numbered 0..num_participants−1. Throws InputError for a link model
  /// with negative or non-finite times or a drop rate outside [0, 1].
  InProcessTransport(int num_participants, const LinkModel& link, std::uint64_t seed);

  void publish(int sender, double now_s, const Message& message) override;
  void receive(int receiver, double now_s, std::vector<Envelope>& out) override;
  TransportStats stats() const override { return stats_; }

 private:
  // One copy of a published message, shared by every receiver's queue (a prediction with its
  // intent is about 2 kB: copying it for each of N − 1 receivers was most of the transport's
  // time in large teams).
  struct Pending {
    int sender = -1;
    double sent_s = 0.0;
    double delivered_s = 0.0;
    std::uint64_t sequence = 0;  // ties in delivery time keep the order of sending
    std::shared_ptr<const Message> message;
  };
  struct Later {
    bool operator()(const Pending& a, const Pending& b) const {
      if (a.delivered_s != b.delivered_s) return a.delivered_s > b.delivered_s;
      return a.sequence > b.sequence;
    }
  };

  int num_participants_;
  LinkModel link_;
  Rng rng_;
  std::uint64_t next_sequence_ = 0;
  std::vector<std::priority_queue<Pending, std::vector<Pending>, Later>> inboxes_;
  TransportStats stats_;
};

}  // namespace ridgeline::swarm
