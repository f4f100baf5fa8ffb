#include "transport_dds/plan_link.hpp"

#include <fmt/format.h>

#include "core/error.hpp"
#include "transport_dds/wire_types.hpp"

namespace ridgeline::transport_dds {

struct PlanLink::Impl {
  std::shared_ptr<DdsParticipant> participant;
  dds_entity_t writer = 0, reader = 0;
  WireArena arena;
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
  const dds_entity_t topic = make_topic_of<messages::ReferencePlan>(p);
  if (publisher) d.writer = make_writer_of<messages::ReferencePlan>(p, topic, part);
  d.reader = make_reader_of<messages::ReferencePlan>(p, topic, part);
}

PlanLink::~PlanLink() {
  if (impl_->writer > 0) dds_delete(impl_->writer);
  if (impl_->reader > 0) dds_delete(impl_->reader);
}

void PlanLink::publish(const messages::ReferencePlan& plan) {
  Impl& d = *impl_;
  if (d.writer == 0) throw InputError("PlanLink", "this end does not publish plans");
  if (auto reason = messages::check_plan(plan, num_uavs_, num_targets_))
    throw InputError(fmt::format("plan of UAV {}", plan.uav), *reason);
  write_message(d.writer, plan, d.arena);
}

void PlanLink::take(std::vector<messages::ReferencePlan>& out, int uav) {
  const auto reject = [&](int of_uav, const std::string& reason) {
    ++rejected_;
    last_rejection_ = fmt::format("ReferencePlan of UAV {}: {}", of_uav, reason);
  };
  take_messages<messages::ReferencePlan>(
      impl_->reader, static_cast<std::uint32_t>(messages::kMaxPlanSamples),
      [&](const auto& sample) { return uav >= 0 && sample.uav != uav; },
      [&](messages::ReferencePlan&& plan) {
        if (auto reason = messages::check_plan(plan, num_uavs_, num_targets_))
          return reject(plan.uav, *reason);
        out.push_back(std::move(plan));
      },
      [&](const auto& sample, const std::string& reason) { reject(sample.uav, reason); });
}

int PlanLink::matched_readers() const {
  if (impl_->writer == 0) return 0;
  dds_publication_matched_status_t status;
  if (dds_get_publication_matched_status(impl_->writer, &status) < 0) return 0;
  return static_cast<int>(status.current_count);
}

}  // namespace ridgeline::transport_dds
