// The swarm's Transport over DDS (issue 7, part 1): the same interface as the in-process
// transport, so an Agent runs unchanged in its own process. One DdsTransport belongs to one
// participant (a UAV, id 0..num_uavs−1, or the ground station, id num_uavs).
//
// Topics (ROS 2 naming: topic /ridgeline/x is DDS topic rt/ridgeline/x; type ridgeline/msg/X is
// DDS type ridgeline::msg::dds_::X_) and QoS (dds_participant.hpp):
//   rt/ridgeline/predicted_trajectory  PredictedTrajectory_  best effort, keep last 1 per UAV
//   rt/ridgeline/threat_report         ThreatReport_         reliable, keep last 16
//   rt/ridgeline/state                 State_                best effort, keep last 1 per UAV
//   rt/ridgeline/reference_plan        ReferencePlan_        reliable, transient local
//
// receive() takes what DDS has delivered, checks every message with swarm::check_message
// (rejected ones are counted in stats().rejected and never handed on), and stamps the
// envelope with the receiver's now_s. The sender of an envelope is the UAV the message names
// (uav / reporter); a plan's sender is the ground station (num_uavs).
//
// An optional emulated link (LinkModel: latency, jitter, loss) is applied on reception to the
// UAV-to-UAV messages (predictions, threat reports, states), in mission time: a message is
// delivered when the receiver's now_s reaches the sender's stamp + latency + U(0, jitter)
// (at once if that has passed). In lock-step, where wall-clock latency means nothing, this is
// the link of the in-process simulation. Plans are exempt: they come over the ground link.
#pragma once

#include <cstdint>
#include <memory>
#include <queue>
#include <string>
#include <vector>

#include "core/random.hpp"
#include "swarm/transport.hpp"
#include "transport_dds/dds_participant.hpp"

namespace ridgeline::transport_dds {

struct DdsTransportOptions {
  int participant_id = 0;  ///< this node: a UAV id, or num_uavs for the ground station
  int num_uavs = 1;
  swarm::LinkModel emulated_link;  ///< zero: DDS's own link only
  std::uint64_t seed = 1;          ///< of the emulated link's loss and jitter
  std::size_t max_points = 1000;   ///< longest accepted prediction
};

class DdsTransport : public swarm::Transport {
 public:
  /// Throws InputError for an id outside 0..num_uavs or an invalid link model.
  DdsTransport(std::shared_ptr<DdsParticipant> participant, const DdsTransportOptions& options);
  ~DdsTransport() override;

  /// Writes `message` (sender must be this transport's participant_id; now_s is unused: the
  /// message carries its own stamp).
  using swarm::Transport::publish;
  void publish(int sender, double now_s, std::shared_ptr<const swarm::Message> message) override;
  /// Delivers to `receiver` (must be this transport's participant_id) what has arrived.
  void receive(int receiver, double now_s, std::vector<swarm::Envelope>& out) override;
  swarm::TransportStats stats() const override { return stats_; }

  /// "Type: reason" of the latest rejected message (empty if none).
  const std::string& last_rejection() const { return last_rejection_; }
  /// Remote readers matched by this transport's writer of plans (ground station's use: are
  /// the agents there yet?).
  int matched_plan_readers() const;
  /// Messages received and kept by the emulated link, not yet due.
  std::size_t pending_count() const { return pending_.size(); }
  /// Newest stamp of a valid prediction of `uav` taken from DDS (before the emulated link),
  /// −∞ before the first; and the valid threat reports of `uav` taken so far. The lock-step
  /// agent waits on these for its neighbours' messages of the previous tick.
  double newest_prediction_stamp(int uav) const;
  std::int64_t reports_taken(int uav) const;
  /// Takes what DDS has delivered into the emulated link's queue without delivering.
  void poll(double now_s);

 private:
  struct Impl;
  // The envelope is held by pointer: the heap moves entries, and GCC 12 misreads moves of
  // the message variant as uses of uninitialized memory (-Wmaybe-uninitialized).
  struct Pending {
    double delivered_s = 0.0;
    std::uint64_t sequence = 0;
    std::unique_ptr<swarm::Envelope> envelope;
  };
  struct Later {
    bool operator()(const Pending& a, const Pending& b) const {
      if (a.delivered_s != b.delivered_s) return a.delivered_s > b.delivered_s;
      return a.sequence > b.sequence;
    }
  };
  void accept(swarm::Message message, int sender, double sent_s, double now_s, bool emulate);

  std::unique_ptr<Impl> impl_;
  DdsTransportOptions options_;
  Rng rng_;
  std::uint64_t next_sequence_ = 0;
  std::priority_queue<Pending, std::vector<Pending>, Later> pending_;
  std::vector<double> newest_prediction_stamp_;
  std::vector<std::int64_t> reports_taken_;
  swarm::TransportStats stats_;
  std::string last_rejection_;
};

}  // namespace ridgeline::transport_dds
