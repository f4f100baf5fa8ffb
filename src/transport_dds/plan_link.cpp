#include "transport_dds/plan_link.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/error.hpp"
#include "transport_dds/dds_support.hpp"
#include "transport_dds/ridgeline_msgs.h"

namespace ridgeline::transport_dds {
namespace {

constexpr std::uint32_t kMaxSamples = 200000;
constexpr std::uint32_t kMaxTargets = 1000;

}  // namespace

std::optional<std::string> check_plan(const PlanMessage& p, int num_uavs, int num_targets,
                                      std::size_t max_samples) {
  if (p.uav < 0 || p.uav >= num_uavs)
    return fmt::format("uav {} is not a UAV of this team (0..{})", p.uav, num_uavs - 1);
  if (p.version < 0) return fmt::format("version {} is negative", p.version);
  if (!(std::isfinite(p.stamp_s) && p.stamp_s >= 0.0))
    return fmt::format("stamp {} s is invalid", p.stamp_s);
  if (p.times_s.size() < 2 || p.times_s.size() > max_samples || p.points.size() != p.times_s.size())
    return fmt::format("{} times and {} points: need 2..{} of each, equally many", p.times_s.size(),
                       p.points.size(), max_samples);
  for (std::size_t k = 0; k < p.times_s.size(); ++k) {
    const mpc::ReferencePoint& q = p.points[k];
    if (!(std::isfinite(p.times_s[k]) && q.position_m.allFinite() && std::isfinite(q.heading_rad) &&
          std::isfinite(q.speed_m_s) && std::isfinite(q.turn_rate_rad_s) &&
          std::isfinite(q.climb_rate_m_s)))
      return fmt::format("sample {} is not finite", k);
    if (k > 0 && !(p.times_s[k] > p.times_s[k - 1]))
      return fmt::format("times are not increasing at sample {}", k);
  }
  for (const int id : p.target_ids)
    if (id < 0 || id >= num_targets)
      return fmt::format("target {} is not a target of the scenario (0..{})", id, num_targets - 1);
  return std::nullopt;
}

struct PlanLink::Impl {
  std::shared_ptr<DdsParticipant> participant;
  dds_entity_t writer = 0, reader = 0;
  std::vector<ridgeline_msg_dds__ReferenceSample_> samples;
  std::vector<std::int32_t> ids;
};

PlanLink::PlanLink(std::shared_ptr<DdsParticipant> participant, int num_uavs, int num_targets,
                   bool publisher)
    : impl_(std::make_unique<Impl>()), num_uavs_(num_uavs), num_targets_(num_targets) {
  if (participant == nullptr) throw InputError("participant", "is required");
  if (num_uavs < 1) throw InputError("num_uavs", "must be at least 1");
  Impl& d = *impl_;
  d.participant = std::move(participant);
  const dds_entity_t p = d.participant->handle();
  const std::string& part = d.participant->partition();
  const dds_entity_t topic =
      make_topic(p, &ridgeline_msg_dds__ReferencePlan__desc, "rt/ridgeline/reference_plan");
  if (publisher) d.writer = make_writer(p, topic, TopicQos::kReliableLatched, 1, part);
  d.reader = make_reader(p, topic, TopicQos::kReliableLatched, 1, part);
}

PlanLink::~PlanLink() {
  if (impl_->writer > 0) dds_delete(impl_->writer);
  if (impl_->reader > 0) dds_delete(impl_->reader);
}

void PlanLink::publish(const PlanMessage& plan) {
  Impl& d = *impl_;
  if (d.writer == 0) throw InputError("PlanLink", "this end does not publish plans");
  if (auto reason = check_plan(plan, num_uavs_, num_targets_))
    throw InputError(fmt::format("plan of UAV {}", plan.uav), *reason);
  d.samples.clear();
  for (std::size_t k = 0; k < plan.times_s.size(); ++k) {
    const mpc::ReferencePoint& q = plan.points[k];
    d.samples.push_back({plan.times_s[k],
                         {q.position_m.x(), q.position_m.y(), q.position_m.z()},
                         q.heading_rad,
                         q.speed_m_s,
                         q.turn_rate_rad_s,
                         q.climb_rate_m_s});
  }
  d.ids.assign(plan.target_ids.begin(), plan.target_ids.end());
  ridgeline_msg_dds__ReferencePlan_ s{};
  s.uav = plan.uav;
  s.version = plan.version;
  s.stamp_s = plan.stamp_s;
  s.full_samples = true;
  s.samples._maximum = s.samples._length = static_cast<std::uint32_t>(d.samples.size());
  s.samples._buffer = d.samples.data();
  s.samples._release = false;
  s.target_ids._maximum = s.target_ids._length = static_cast<std::uint32_t>(d.ids.size());
  s.target_ids._buffer = d.ids.data();
  s.target_ids._release = false;
  dds_check(dds_write(d.writer, &s), "dds_write(reference_plan)");
}

void PlanLink::take(std::vector<PlanMessage>& out, int uav) {
  take_all<ridgeline_msg_dds__ReferencePlan_>(impl_->reader, [&](const auto& s) {
    if (uav >= 0 && s.uav != uav) return;
    std::string reason;
    if (!s.full_samples) reason = "carries waypoints only, not the reference samples";
    if (s.samples._length > kMaxSamples || s.target_ids._length > kMaxTargets)
      reason = fmt::format("{} samples and {} targets, too many", s.samples._length,
                           s.target_ids._length);
    PlanMessage p;
    if (reason.empty()) {
      p.uav = s.uav;
      p.version = s.version;
      p.stamp_s = s.stamp_s;
      for (std::uint32_t k = 0; k < s.samples._length; ++k) {
        const ridgeline_msg_dds__ReferenceSample_& q = s.samples._buffer[k];
        p.times_s.push_back(q.t_s);
        p.points.push_back({Vec3(q.position_m.x, q.position_m.y, q.position_m.z), q.heading_rad,
                            q.speed_m_s, q.turn_rate_rad_s, q.climb_rate_m_s});
      }
      p.target_ids.assign(s.target_ids._buffer, s.target_ids._buffer + s.target_ids._length);
      if (auto e = check_plan(p, num_uavs_, num_targets_)) reason = *e;
    }
    if (!reason.empty()) {
      ++rejected_;
      last_rejection_ = fmt::format("ReferencePlan of UAV {}: {}", s.uav, reason);
      return;
    }
    out.push_back(std::move(p));
  });
}

int PlanLink::matched_readers() const {
  if (impl_->writer == 0) return 0;
  dds_publication_matched_status_t status;
  if (dds_get_publication_matched_status(impl_->writer, &status) < 0) return 0;
  return static_cast<int>(status.current_count);
}

}  // namespace ridgeline::transport_dds
