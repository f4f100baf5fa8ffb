#include "transport_dds/dds_transport.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"
#include "transport_dds/dds_support.hpp"
#include "transport_dds/ridgeline_msgs.h"

namespace ridgeline::transport_dds {
namespace {

using V3 = ridgeline_msg_dds__Vector3_;
V3 to_dds(const Vec3& v) { return V3{v.x(), v.y(), v.z()}; }
Vec3 from_dds(const V3& v) { return Vec3(v.x, v.y, v.z); }

constexpr const char* kPredictionTopic = "rt/ridgeline/predicted_trajectory";
constexpr const char* kThreatTopic = "rt/ridgeline/threat_report";
constexpr const char* kStateTopic = "rt/ridgeline/state";
constexpr const char* kPlanTopic = "rt/ridgeline/reference_plan";
constexpr std::uint32_t kMaxPlanSamples = 200000;  // a 600 s plan at 20 ms is 30 000

}  // namespace

struct DdsTransport::Impl {
  std::shared_ptr<DdsParticipant> participant;
  dds_entity_t prediction_writer = 0, prediction_reader = 0;
  dds_entity_t threat_writer = 0, threat_reader = 0;
  dds_entity_t state_writer = 0, state_reader = 0;
  dds_entity_t plan_writer = 0, plan_reader = 0;
  // Scratch buffers the C samples point into while written.
  std::vector<V3> points;
  std::vector<ridgeline_msg_dds__ReferenceSample_> samples;
  std::vector<std::int32_t> ids;
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
  const dds_entity_t prediction =
      make_topic(p, &ridgeline_msg_dds__PredictedTrajectory__desc, kPredictionTopic);
  const dds_entity_t threat = make_topic(p, &ridgeline_msg_dds__ThreatReport__desc, kThreatTopic);
  const dds_entity_t state = make_topic(p, &ridgeline_msg_dds__State__desc, kStateTopic);
  const dds_entity_t plan = make_topic(p, &ridgeline_msg_dds__ReferencePlan__desc, kPlanTopic);
  d.prediction_writer = make_writer(p, prediction, TopicQos::kLatestBestEffort, 1, part);
  d.prediction_reader = make_reader(p, prediction, TopicQos::kLatestBestEffort, 1, part);
  d.threat_writer = make_writer(p, threat, TopicQos::kReliable, 16, part);
  d.threat_reader = make_reader(p, threat, TopicQos::kReliable, 16, part);
  d.state_writer = make_writer(p, state, TopicQos::kLatestBestEffort, 1, part);
  d.state_reader = make_reader(p, state, TopicQos::kLatestBestEffort, 1, part);
  d.plan_writer = make_writer(p, plan, TopicQos::kReliableLatched, 1, part);
  d.plan_reader = make_reader(p, plan, TopicQos::kReliableLatched, 1, part);
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

void DdsTransport::publish(int sender, double /*now_s*/, const swarm::Message& message) {
  if (sender != options_.participant_id)
    throw InputError("sender", fmt::format("this transport publishes for participant {}, not {}",
                                           options_.participant_id, sender));
  Impl& d = *impl_;
  ++stats_.published;
  if (const auto* p = std::get_if<swarm::PredictedTrajectory>(&message)) {
    d.points.clear();
    for (const Vec3& q : p->positions_m) d.points.push_back(to_dds(q));
    ridgeline_msg_dds__PredictedTrajectory_ s{};
    s.uav = p->uav;
    s.stamp_s = p->stamp_s;
    s.step_s = p->step_s;
    s.positions_m._maximum = s.positions_m._length = static_cast<std::uint32_t>(d.points.size());
    s.positions_m._buffer = d.points.data();
    s.positions_m._release = false;
    dds_check(dds_write(d.prediction_writer, &s), "dds_write(predicted_trajectory)");
  } else if (const auto* r = std::get_if<swarm::ThreatReport>(&message)) {
    ridgeline_msg_dds__ThreatReport_ s{};
    s.reporter = r->reporter;
    s.threat_id = r->threat_id;
    s.stamp_s = r->stamp_s;
    s.centre_m = to_dds(r->centre_m);
    s.velocity_m_s = to_dds(r->velocity_m_s);
    s.radius_m = r->radius_m;
    dds_check(dds_write(d.threat_writer, &s), "dds_write(threat_report)");
  } else if (const auto* st = std::get_if<swarm::StateReport>(&message)) {
    ridgeline_msg_dds__State_ s{};
    s.uav = st->uav;
    s.stamp_s = st->stamp_s;
    for (int k = 0; k < 7; ++k) s.s[k] = st->state[k];
    dds_check(dds_write(d.state_writer, &s), "dds_write(state)");
  } else if (const auto* pl = std::get_if<swarm::ReferencePlan>(&message)) {
    if (pl->waypoints_m.size() != pl->times_s.size())
      throw InputError("ReferencePlan", "waypoints and times differ in length");
    d.samples.clear();
    for (std::size_t k = 0; k < pl->times_s.size(); ++k) {
      ridgeline_msg_dds__ReferenceSample_ q{};
      q.t_s = pl->times_s[k];
      q.position_m = to_dds(pl->waypoints_m[k]);
      d.samples.push_back(q);
    }
    ridgeline_msg_dds__ReferencePlan_ s{};
    s.uav = pl->uav;
    s.stamp_s = pl->stamp_s;
    s.full_samples = false;
    s.samples._maximum = s.samples._length = static_cast<std::uint32_t>(d.samples.size());
    s.samples._buffer = d.samples.data();
    s.samples._release = false;
    dds_check(dds_write(d.plan_writer, &s), "dds_write(reference_plan)");
  }
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
  pending_.push(
      Pending{swarm::Envelope{sender, sent_s, delivered_s, std::move(message)}, next_sequence_++});
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
  while (!pending_.empty() && pending_.top().envelope.delivered_s <= now_s) {
    out.push_back(pending_.top().envelope);
    pending_.pop();
    ++stats_.delivered;
  }
}

void DdsTransport::poll(double now_s) {
  Impl& d = *impl_;
  const swarm::LinkModel& link = options_.emulated_link;
  const bool emulate = link.latency_s > 0.0 || link.jitter_s > 0.0 || link.drop_rate > 0.0;
  take_all<ridgeline_msg_dds__PredictedTrajectory_>(d.prediction_reader, [&](const auto& s) {
    swarm::PredictedTrajectory m;
    m.uav = s.uav;
    m.stamp_s = s.stamp_s;
    m.step_s = s.step_s;
    // The length is checked before copying: a forged length must not allocate gigabytes.
    if (s.positions_m._length <= options_.max_points) {
      m.positions_m.reserve(s.positions_m._length);
      for (std::uint32_t k = 0; k < s.positions_m._length; ++k)
        m.positions_m.push_back(from_dds(s.positions_m._buffer[k]));
    } else {
      m.positions_m.resize(options_.max_points + 1, Vec3::Zero());
    }
    accept(std::move(m), s.uav, s.stamp_s, now_s, emulate);
  });
  take_all<ridgeline_msg_dds__ThreatReport_>(d.threat_reader, [&](const auto& s) {
    swarm::ThreatReport m;
    m.reporter = s.reporter;
    m.threat_id = s.threat_id;
    m.stamp_s = s.stamp_s;
    m.centre_m = from_dds(s.centre_m);
    m.velocity_m_s = from_dds(s.velocity_m_s);
    m.radius_m = s.radius_m;
    accept(std::move(m), s.reporter, s.stamp_s, now_s, emulate);
  });
  take_all<ridgeline_msg_dds__State_>(d.state_reader, [&](const auto& s) {
    swarm::StateReport m;
    m.uav = s.uav;
    m.stamp_s = s.stamp_s;
    for (int k = 0; k < 7; ++k) m.state[k] = s.s[k];
    accept(std::move(m), s.uav, s.stamp_s, now_s, emulate);
  });
  take_all<ridgeline_msg_dds__ReferencePlan_>(d.plan_reader, [&](const auto& s) {
    // The plan as waypoints and times (PlanLink reads the full reference samples).
    swarm::ReferencePlan m;
    m.uav = s.uav;
    m.stamp_s = s.stamp_s;
    const std::uint32_t n = s.samples._length;
    if (n > kMaxPlanSamples) {
      ++stats_.rejected;
      last_rejection_ = fmt::format("ReferencePlan: {} samples, at most {}", n, kMaxPlanSamples);
      return;
    }
    for (std::uint32_t k = 0; k < n; ++k) {
      m.times_s.push_back(s.samples._buffer[k].t_s);
      m.waypoints_m.push_back(from_dds(s.samples._buffer[k].position_m));
    }
    accept(std::move(m), options_.num_uavs, s.stamp_s, now_s, false);
  });
}

}  // namespace ridgeline::transport_dds
