// Helpers of this folder's .cpp files (includes dds/dds.h; not for the layers above).
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <string>

#include "transport_dds/topics.hpp"

namespace ridgeline::transport_dds {

/// Returns `rc` when it is a valid handle or success; throws std::runtime_error naming `what`
/// and DDS's reason otherwise.
std::int32_t dds_check(std::int32_t rc, const char* what);


/// A topic of `descriptor`'s type named `name` on `participant`.
dds_entity_t make_topic(dds_entity_t participant, const dds_topic_descriptor_t* descriptor,
                        const char* name);
/// A writer (reader) of `topic` in `partition` (empty: the default partition).
dds_entity_t make_writer(dds_entity_t participant, dds_entity_t topic, TopicQos qos, int depth,
                         const std::string& partition);
/// Readers ignore their own participant's samples.
dds_entity_t make_reader(dds_entity_t participant, dds_entity_t topic, TopicQos qos, int depth,
                         const std::string& partition);

/// Takes every available sample of `reader` (loaned, returned after `visit` saw them) and
/// calls visit(const T&) on each valid one. Returns how many were visited.
template <typename T, typename Visit>
int take_all(dds_entity_t reader, Visit&& visit) {
  constexpr int kBatch = 32;
  int total = 0;
  for (;;) {
    void* samples[kBatch] = {};
    dds_sample_info_t infos[kBatch];
    const dds_return_t n = dds_take(reader, samples, infos, kBatch, kBatch);
    if (n <= 0) return total;
    for (dds_return_t k = 0; k < n; ++k) {
      if (!infos[k].valid_data) continue;
      visit(*static_cast<const T*>(samples[k]));
      ++total;
    }
    dds_return_loan(reader, samples, n);
    if (n < kBatch) return total;
  }
}

}  // namespace ridgeline::transport_dds
