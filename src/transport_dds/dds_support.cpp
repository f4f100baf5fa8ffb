#include "transport_dds/dds_support.hpp"

#include <stdexcept>

namespace ridgeline::transport_dds {

std::int32_t dds_check(std::int32_t rc, const char* what) {
  if (rc < 0)
    throw std::runtime_error(std::string("DDS: ") + what + " failed: " + dds_strretcode(rc));
  return rc;
}

dds_entity_t make_topic(dds_entity_t participant, const dds_topic_descriptor_t* descriptor,
                        const char* name) {
  return dds_check(dds_create_topic(participant, descriptor, name, nullptr, nullptr),
                   "dds_create_topic");
}

namespace {

dds_qos_t* make_qos(TopicQos qos, int depth, bool reader, const std::string& partition) {
  dds_qos_t* q = dds_create_qos();
  if (!partition.empty()) dds_qset_partition1(q, partition.c_str());
  switch (qos) {
    case TopicQos::kLatestBestEffort:
      dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      break;
    case TopicQos::kReliable:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
      break;
    case TopicQos::kReliableLatched:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
      dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      break;
    case TopicQos::kPx4Publisher:
      dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
      dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      break;
    case TopicQos::kPx4Subscriber:
      dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
      dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      break;
  }
  if (reader) dds_qset_ignorelocal(q, DDS_IGNORELOCAL_PARTICIPANT);
  return q;
}

}  // namespace

dds_entity_t make_writer(dds_entity_t participant, dds_entity_t topic, TopicQos qos, int depth,
                         const std::string& partition) {
  dds_qos_t* q = make_qos(qos, depth, false, partition);
  const dds_entity_t writer = dds_create_writer(participant, topic, q, nullptr);
  dds_delete_qos(q);
  return dds_check(writer, "dds_create_writer");
}

dds_entity_t make_reader(dds_entity_t participant, dds_entity_t topic, TopicQos qos, int depth,
                         const std::string& partition) {
  dds_qos_t* q = make_qos(qos, depth, true, partition);
  const dds_entity_t reader = dds_create_reader(participant, topic, q, nullptr);
  dds_delete_qos(q);
  return dds_check(reader, "dds_create_reader");
}

}  // namespace ridgeline::transport_dds
