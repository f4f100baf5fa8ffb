// Transport inside one process, for simulation: deterministic for a seed, with the latency,
// jitter (and so reordering) and loss of a LinkModel.
//
// Delivery by distance (PredictionReach; issue 20). Every agent broadcasts its prediction
// every tick: delivered to every other agent that is N² copies a tick, what made 100-UAV
// flights slow. With a finite reach_m a PredictedTrajectory goes at once only to the
// participants within reach_m of its sender — found on a grid of reach_m cells over the
// participants' last broadcast positions (rebuilt once a broadcast period, when the publishing
// time moves on), so a broadcast costs the neighbours within reach, not the team — and to all
// the others only once every far_period_s (each sender on its own phase), so a far neighbour is
// never forgotten nor older than far_period_s plus the link's delay: the agents' longer
// look-aheads (conflicts, separation levels, which re-plan every second) still see everyone.
// A participant that has not broadcast a prediction yet (no position) receives everything.
// Other messages go to everyone as before: a threat report may matter to a UAV whose route
// passes the threat much later, and they are rare (≤ 1 Hz per sensed threat); plans and state
// reports are for the ground station.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <queue>
#include <unordered_map>
#include <vector>

#include "core/random.hpp"
#include "swarm/transport.hpp"

namespace ridgeline::swarm {

/// Which participants a PredictedTrajectory reaches (file comment). The default: everyone.
struct PredictionReach {
  double reach_m = std::numeric_limits<double>::infinity();  ///< > 0
  double far_period_s = 0.25;  ///< > 0: beyond reach_m, one prediction a sender this often
};

class InProcessTransport : public Transport {
 public:
  /// Participants are numbered 0..num_participants−1. Throws InputError for a link model
  /// with negative or non-finite times or a drop rate outside [0, 1], or a reach that is not
  /// > 0 or a far period that is not finite and > 0.
  InProcessTransport(int num_participants, const LinkModel& link, std::uint64_t seed,
                     const PredictionReach& reach = {});

  using Transport::publish;
  void publish(int sender, double now_s, std::shared_ptr<const Message> message) override;
  void receive(int receiver, double now_s, std::vector<Envelope>& out) override;
  TransportStats stats() const override { return stats_; }

 private:
  // The published message itself, shared by every receiver's queue and then envelope (a
  // prediction with its intent is about 2 kB: copying it for each of N − 1 receivers was most of
  // the transport's time in large teams).
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

  void rebuild_grid();
  std::int64_t cell_key(const Vec3& p) const;

  int num_participants_;
  LinkModel link_;
  PredictionReach reach_;
  std::vector<std::optional<Vec3>> positions_;  // each one's last broadcast position
  std::unordered_map<std::int64_t, std::vector<int>> grid_;  // cell → participants
  double grid_time_s_ = -std::numeric_limits<double>::infinity();
  std::vector<double> next_far_s_;  // per sender: its next prediction to everyone
  std::vector<int> unplaced_;       // participants without a position (at the last rebuild)
  std::vector<int> near_;           // scratch: the receivers found on the grid
  Rng rng_;
  std::uint64_t next_sequence_ = 0;
  std::vector<std::priority_queue<Pending, std::vector<Pending>, Later>> inboxes_;
  TransportStats stats_;
};

}  // namespace ridgeline::swarm
