// One DDS domain participant (Eclipse Cyclone DDS) and the QoS Ridgeline's topics use.
// Only src/transport_dds knows DDS: this header exposes no DDS type, so the layers above
// (processes, apps) never include dds/dds.h.
//
// The topics, their QoS and why: topics.hpp (the one place they are written).
// All readers ignore samples written by their own participant. Readers and writers are in
// DdsOptions::partition.
//
// Discovery: with loopback_only the participant uses only the loopback interface, unicast
// discovery to 127.0.0.1 (lo has no multicast) and automatic participant indices, so several
// processes and tests on one machine find each other without touching the network. Domain
// ids 0..230 (Cyclone's ports 7400 + 250·domain + … stay below 65536); give every test and
// every launch a domain id of its own.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

namespace ridgeline::transport_dds {

struct DdsOptions {
  int domain_id = 42;
  bool loopback_only = true;
  /// Highest automatic participant index (participants on this machine and domain − 1).
  int max_participants = 64;
  /// DDS partition of every reader and writer. Empty (the default partition) is what ROS 2
  /// uses; a name of its own per run (tests, launch) keeps concurrent runs on one domain apart.
  std::string partition;
};

/// Throws InputError("domain_id", ...) outside 0..230, std::runtime_error when DDS refuses (the
/// message names the call and DDS's reason).
class DdsParticipant {
 public:
  explicit DdsParticipant(const DdsOptions& options);
  ~DdsParticipant();
  DdsParticipant(const DdsParticipant&) = delete;
  DdsParticipant& operator=(const DdsParticipant&) = delete;

  int domain_id() const { return options_.domain_id; }
  const std::string& partition() const { return options_.partition; }
  /// The participant's DDS handle (dds_entity_t), for the classes of this folder.
  std::int32_t handle() const { return handle_; }

 private:
  DdsOptions options_;
  std::int32_t handle_ = 0;
};

/// The Cyclone DDS configuration (XML) a participant with these options uses.
std::string cyclone_config(const DdsOptions& options);

}  // namespace ridgeline::transport_dds
