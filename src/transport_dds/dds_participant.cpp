#include "transport_dds/dds_participant.hpp"

#include <dds/dds.h>
#include <fmt/format.h>

#include <map>
#include <mutex>
#include <stdexcept>

#include "core/error.hpp"
#include "transport_dds/dds_support.hpp"

namespace ridgeline::transport_dds {
namespace {

// Cyclone creates a domain once per process; participants of this process share it. The
// registry counts participants so the domain (and its threads and sockets) goes with the
// last one.
struct DomainRegistry {
  std::mutex mutex;
  std::map<int, std::pair<dds_entity_t, int>> domains;  // id -> (handle, participants)
};
DomainRegistry& registry() {
  static DomainRegistry r;
  return r;
}

}  // namespace

std::string cyclone_config(const DdsOptions& options) {
  if (!options.loopback_only) return "";
  return fmt::format(
      "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"lo\"/>"
      "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
      "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>{}"
      "</MaxAutoParticipantIndex><Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery>"
      "<Tracing><Verbosity>none</Verbosity></Tracing></Domain></CycloneDDS>",
      options.max_participants);
}

DdsParticipant::DdsParticipant(const DdsOptions& options) : options_(options) {
  if (options.domain_id < 0 || options.domain_id > 230)
    throw InputError("domain_id", fmt::format("must be in 0..230, got {}", options.domain_id));
  if (options.max_participants < 2 || options.max_participants > 120)
    throw InputError("max_participants",
                     fmt::format("must be in 2..120, got {}", options.max_participants));
  {
    std::lock_guard<std::mutex> lock(registry().mutex);
    auto& entry = registry().domains[options.domain_id];
    if (entry.second == 0) {
      const std::string config = cyclone_config(options);
      const dds_entity_t domain = dds_create_domain(static_cast<dds_domainid_t>(options.domain_id),
                                                    config.empty() ? nullptr : config.c_str());
      entry.first = dds_check(domain, "dds_create_domain");
    }
    ++entry.second;
  }
  handle_ =
      dds_create_participant(static_cast<dds_domainid_t>(options.domain_id), nullptr, nullptr);
  if (handle_ < 0) {
    const std::string reason = dds_strretcode(handle_);
    std::lock_guard<std::mutex> lock(registry().mutex);
    auto& entry = registry().domains[options.domain_id];
    if (--entry.second == 0) {
      dds_delete(entry.first);
      registry().domains.erase(options.domain_id);
    }
    throw std::runtime_error("DDS: dds_create_participant failed: " + reason);
  }
}

DdsParticipant::~DdsParticipant() {
  dds_delete(handle_);
  std::lock_guard<std::mutex> lock(registry().mutex);
  auto it = registry().domains.find(options_.domain_id);
  if (it != registry().domains.end() && --it->second.second == 0) {
    dds_delete(it->second.first);
    registry().domains.erase(it);
  }
}

}  // namespace ridgeline::transport_dds
