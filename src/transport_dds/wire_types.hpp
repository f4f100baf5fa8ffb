// The C type and topic descriptor idlc generated for each message type, and the few generic
// operations every link does with them: create its topic, reader and writer from the topics'
// table, write a message, take and convert the received ones. For this folder's .cpp files.
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "transport_dds/dds_support.hpp"
#include "transport_dds/px4_msgs.h"
#include "transport_dds/ridgeline_msgs.h"
#include "transport_dds/topics.hpp"
#include "transport_dds/wire_conversion.hpp"

namespace ridgeline::transport_dds {

/// WireType<M>::Sample is idlc's struct of message type M; descriptor() its type descriptor.
template <class M>
struct WireType;

// idlc names a struct package::msg::dds_::Name_ as package_msg_dds__Name_.
#define RIDGELINE_WIRE_TYPE(Message, package, Name)                               \
  template <>                                                                     \
  struct WireType<Message> {                                                      \
    static_assert(std::string_view(messages::WireFields<Message>::name) == #Name, \
                  "the wire name in RIDGELINE_WIRE_FIELDS and here differ");      \
    using Sample = package##_msg_dds__##Name##_;                                  \
    static const dds_topic_descriptor_t* descriptor() {                           \
      return &package##_msg_dds__##Name##__desc;                                  \
    }                                                                             \
  };
RIDGELINE_WIRE_TYPE(messages::PredictedTrajectory, ridgeline, PredictedTrajectory)
RIDGELINE_WIRE_TYPE(messages::ThreatReport, ridgeline, ThreatReport)
RIDGELINE_WIRE_TYPE(messages::StateReport, ridgeline, State)
RIDGELINE_WIRE_TYPE(messages::ReferencePlan, ridgeline, ReferencePlan)
RIDGELINE_WIRE_TYPE(ClockTick, ridgeline, Clock)
RIDGELINE_WIRE_TYPE(Measurement, ridgeline, Measurement)
RIDGELINE_WIRE_TYPE(CommandReport, ridgeline, Command)
RIDGELINE_WIRE_TYPE(px4::OffboardControlMode, px4_msgs, OffboardControlMode)
RIDGELINE_WIRE_TYPE(px4::TrajectorySetpoint, px4_msgs, TrajectorySetpoint)
RIDGELINE_WIRE_TYPE(px4::VehicleCommand, px4_msgs, VehicleCommand)
RIDGELINE_WIRE_TYPE(px4::VehicleOdometry, px4_msgs, VehicleOdometry)
RIDGELINE_WIRE_TYPE(px4::VehicleStatus, px4_msgs, VehicleStatus)
#undef RIDGELINE_WIRE_TYPE

/// M's topic (topics.hpp) on `participant`.
template <class M>
dds_entity_t make_topic_of(dds_entity_t participant) {
  return make_topic(participant, WireType<M>::descriptor(), Topic<M>::spec.name);
}

/// A writer (reader) of M's topic with the table's QoS.
template <class M>
dds_entity_t make_writer_of(dds_entity_t participant, dds_entity_t topic,
                            const std::string& partition) {
  return make_writer(participant, topic, Topic<M>::spec.qos, Topic<M>::spec.depth, partition);
}
template <class M>
dds_entity_t make_reader_of(dds_entity_t participant, dds_entity_t topic,
                            const std::string& partition) {
  return make_reader(participant, topic, Topic<M>::spec.qos, Topic<M>::spec.depth, partition);
}

/// Writes `message` on `writer` (converted through `arena`).
template <class M>
void write_message(dds_entity_t writer, const M& message, WireArena& arena) {
  arena.reset();
  typename WireType<M>::Sample sample{};
  to_wire(message, sample, arena);
  dds_check(dds_write(writer, &sample), Topic<M>::spec.name);
}

/// Takes every sample of `reader`; for each, calls skip(sample) (true: ignore it, e.g. another
/// UAV's), then converts it (sequences of at most `max_length`) and calls accept(M&&) or, when
/// the conversion refuses it, reject(sample, reason).
template <class M, class Skip, class Accept, class Reject>
void take_messages(dds_entity_t reader, std::uint32_t max_length, Skip&& skip, Accept&& accept,
                   Reject&& reject) {
  using Sample = typename WireType<M>::Sample;
  take_all<Sample>(reader, [&](const Sample& sample) {
    if (skip(sample)) return;
    M message;
    if (std::optional<std::string> reason = from_wire(sample, message, max_length))
      reject(sample, *reason);
    else
      accept(std::move(message));
  });
}

}  // namespace ridgeline::transport_dds
