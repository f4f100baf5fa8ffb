#include "transport_dds/dds_transport.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <type_traits>
#include <utility>

#include "core/error.hpp"
#include "transport_dds/wire_types.hpp"

namespace ridgeline::transport_dds {
namespace {

// The Transport's message types (the alternatives of messages::Message), as a type list.
using MessageTypes = std::tuple<messages::PredictedTrajectory*, messages::ThreatReport*,
                                messages::StateReport*, messages::ReferencePlan*>;

}  // namespace

struct DdsTransport::Impl {
  std::shared_ptr<DdsParticipant> participant;
  dds_entity_t prediction_writer = 0, prediction_reader = 0;
  dds_entity_t threat_writer = 0, threat_reader = 0;
  dds_entity_t state_writer = 0, state_reader = 0;
  dds_entity_t plan_writer = 0, plan_reader = 0;
  WireArena arena;  // what an outgoing sample's sequences point into while it is written

  /// M's writer and reader.
  template <class M>
  std::pair<dds_entity_t*, dds_entity_t*> ends() {
    if constexpr (std::is_same_v<M, messages::PredictedTrajectory>)
      return {&prediction_writer, &prediction_reader};
    else if constexpr (std::is_same_v<M, messages::ThreatReport>)
      return {&threat_writer, &threat_reader};
    else if constexpr (std::is_same_v<M, messages::StateReport>)
      return {&state_writer, &state_reader};
    else
      return {&plan_writer, &plan_reader};
  }
};

DdsTransport::DdsTransport(std::shared_ptr<DdsParticipant> participant,
                           const DdsTransportOptions& options)
    : impl_(std::make_unique<Impl>()), options_(options), rng_(options.seed) {
  if (participant == nullptr) throw InputError("participant", "is required");
  if (options.num_uavs < 1) throw InputError("num_uavs", "must be at least 1");
  if (options.participant_id < 0 || options.participant_id > options.num_uavs)
    throw InputError("participant_id", fmt::format("must be in 0..{} (UAVs, then the ground "
                                                   "station), got {}",
                                                   options.num_uavs, options.participant_id));
  const swarm::LinkModel& link = options.emulated_link;
  if (!(std::isfinite(link.latency_s) && link.latency_s >= 0.0))
    throw InputError("link.latency_s", fmt::format("must be >= 0, got {}", link.latency_s));
  if (!(std::isfinite(link.jitter_s) && link.jitter_s >= 0.0))
    throw InputError("link.jitter_s", fmt::format("must be >= 0, got {}", link.jitter_s));
  if (!(link.drop_rate >= 0.0 && link.drop_rate <= 1.0))
    throw InputError("link.drop_rate", fmt::format("must be in [0, 1], got {}", link.drop_rate));
  newest_prediction_stamp_.assign(static_cast<std::size_t>(options.num_uavs),
                                  -std::numeric_limits<double>::infinity());
  reports_taken_.assign(static_cast<std::size_t>(options.num_uavs), 0);
  Impl& d = *impl_;
  d.participant = std::move(participant);
  const dds_entity_t p = d.participant->handle();
  const std::string& part = d.participant->partition();
  // Every message type of the Transport: its topic, writer and reader (topics.hpp).
  auto open = [&]<class M>(M*) {
    const dds_entity_t topic = make_topic_of<M>(p);
    auto [writer, reader] = d.ends<M>();
    *writer = make_writer_of<M>(p, topic, part);
    *reader = make_reader_of<M>(p, topic, part);
  };
  std::apply([&](auto*... types) { (open(types), ...); }, MessageTypes{});
}

DdsTransport::~DdsTransport() {
  const Impl& d = *impl_;
  for (const dds_entity_t e :
       {d.prediction_writer, d.prediction_reader, d.threat_writer, d.threat_reader, d.state_writer,
        d.state_reader, d.plan_writer, d.plan_reader})
    if (e > 0) dds_delete(e);
}

int DdsTransport::matched_plan_readers() const {
  dds_publication_matched_status_t status;
  if (dds_get_publication_matched_status(impl_->plan_writer, &status) < 0) return 0;
  return static_cast<int>(status.current_count);
}

void DdsTransport::publish(int sender, double /*now_s*/,
                           std::shared_ptr<const swarm::Message> message) {
  if (sender != options_.participant_id)
    throw InputError("sender", fmt::format("this transport publishes for participant {}, not {}",
                                           options_.participant_id, sender));
  if (message == nullptr) throw InputError("message", "is null");
  Impl& d = *impl_;
  ++stats_.published;
  std::visit(
      [&](const auto& m) {
        write_message(*d.ends<std::remove_cvref_t<decltype(m)>>().first, m, d.arena);
      },
      *message);
  ++stats_.sent;
}

void DdsTransport::accept(swarm::Message message, int sender, double sent_s, double now_s,
                          bool emulate) {
  if (auto reason = swarm::check_message(message, options_.num_uavs, options_.max_points)) {
    ++stats_.rejected;
    last_rejection_ = fmt::format("{}: {}", swarm::message_type_name(message), *reason);
    return;
  }
  if (const auto* p = std::get_if<swarm::PredictedTrajectory>(&message)) {
    double& newest = newest_prediction_stamp_[static_cast<std::size_t>(p->uav)];
    newest = std::max(newest, p->stamp_s);
  } else if (const auto* r = std::get_if<swarm::ThreatReport>(&message)) {
    ++reports_taken_[static_cast<std::size_t>(r->reporter)];
  }
  const swarm::LinkModel& link = options_.emulated_link;
  double delivered_s = now_s;
  if (emulate) {
    // Draw both numbers for every copy so the random stream does not depend on the outcome.
    const double loss_draw = rng_.uniform();
    const double jitter = link.jitter_s * rng_.uniform();
    if (loss_draw < link.drop_rate) {
      ++stats_.dropped;
      return;
    }
    // In mission time from the sender's stamp, as the in-process transport: a message is never
    // seen in the tick it was sent, whatever DDS's own (wall-clock) delivery time was.
    delivered_s = std::max(now_s, sent_s + link.latency_s + jitter);
  }
  pending_.push(Pending{delivered_s, next_sequence_++,
                        std::make_unique<swarm::Envelope>(
                            swarm::Envelope{sender, sent_s, delivered_s, std::move(message)})});
}

double DdsTransport::newest_prediction_stamp(int uav) const {
  if (uav < 0 || uav >= options_.num_uavs) return -std::numeric_limits<double>::infinity();
  return newest_prediction_stamp_[static_cast<std::size_t>(uav)];
}

std::int64_t DdsTransport::reports_taken(int uav) const {
  if (uav < 0 || uav >= options_.num_uavs) return 0;
  return reports_taken_[static_cast<std::size_t>(uav)];
}

void DdsTransport::receive(int receiver, double now_s, std::vector<swarm::Envelope>& out) {
  if (receiver != options_.participant_id)
    throw InputError("receiver", fmt::format("this transport receives for participant {}, not {}",
                                             options_.participant_id, receiver));
  poll(now_s);
  while (!pending_.empty() && pending_.top().delivered_s <= now_s) {
    out.push_back(std::move(*pending_.top().envelope));
    pending_.pop();
    ++stats_.delivered;
  }
}

void DdsTransport::poll(double now_s) {
  Impl& d = *impl_;
  const swarm::LinkModel& link = options_.emulated_link;
  const bool emulate = link.latency_s > 0.0 || link.jitter_s > 0.0 || link.drop_rate > 0.0;
  // A plan's samples are bounded by kMaxPlanSamples, every other sequence by max_points; the
  // lengths are checked before anything is allocated for them (a forged length must not
  // allocate gigabytes), the rest by check_message in accept().
  auto take = [&]<class M>(M*) {
    const std::uint32_t max_length = static_cast<std::uint32_t>(
        std::is_same_v<M, messages::ReferencePlan> ? messages::kMaxPlanSamples
                                                   : options_.max_points);
    take_messages<M>(
        *d.ends<M>().second, max_length, [](const auto&) { return false; },
        [&](M&& m) {
          // Who sent it and when, as the message says; a plan comes from the ground station.
          int sender = options_.num_uavs;
          if constexpr (std::is_same_v<M, messages::ThreatReport>)
            sender = m.reporter;
          else if constexpr (!std::is_same_v<M, messages::ReferencePlan>)
            sender = m.uav;
          const double sent_s = m.stamp_s;
          const bool delayed = emulate && !std::is_same_v<M, messages::ReferencePlan>;
          accept(std::move(m), sender, sent_s, now_s, delayed);
        },
        [&](const auto&, const std::string& reason) {
          ++stats_.rejected;
          last_rejection_ = fmt::format("{}: {}", messages::WireFields<M>::name, reason);
        });
  };
  std::apply([&](auto*... types) { (take(types), ...); }, MessageTypes{});
}

}  // namespace ridgeline::transport_dds
