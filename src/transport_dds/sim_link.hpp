// The world simulator's side channel over DDS (issue 7, part 2): the shared clock, each UAV's
// measurements (what its sensors give it: state fix, anemometer, threats in sensor range) and
// the agents' answers (command and what the world records of the agent). On vehicles this
// channel is the autopilot's sensors and flight controller, not the radio: it is never lossy
// and is not part of the Transport interface the agents use among themselves.
//
// Every sample is checked on reception (finite numbers, ids in range, sizes bounded);
// rejected ones are counted and the last reason kept, never acted on.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "transport_dds/dds_participant.hpp"
#include "transport_dds/sim_messages.hpp"

namespace ridgeline::transport_dds {

/// Which ends of the channel a node holds.
struct SimLinkRole {
  bool publishes_clock = false;         ///< the world
  bool publishes_measurements = false;  ///< the world
  bool publishes_commands = false;      ///< an agent
  bool reads_clock = false;
  bool reads_measurements = false;
  bool reads_commands = false;
};
SimLinkRole world_role();
SimLinkRole agent_role();
SimLinkRole observer_role();  ///< ground station and launcher: clock, measurements, commands

struct SimLinkStats {
  std::uint64_t published = 0;
  std::uint64_t received = 0;
  std::uint64_t rejected = 0;
  std::string last_rejection;  ///< "Type: reason" of the latest rejected sample
};

class SimLink {
 public:
  /// `num_uavs` bounds the ids accepted. Throws InputError for num_uavs < 1.
  SimLink(std::shared_ptr<DdsParticipant> participant, int num_uavs, const SimLinkRole& role);
  ~SimLink();
  SimLink(const SimLink&) = delete;
  SimLink& operator=(const SimLink&) = delete;

  void publish(const ClockTick& clock);
  void publish(const Measurement& measurement);
  void publish(const CommandReport& command);

  /// Append every valid sample received since the last call (rejects are counted).
  void take(std::vector<ClockTick>& out);
  /// Only `uav`'s measurements when uav ≥ 0 (the others are discarded).
  void take(std::vector<Measurement>& out, int uav = -1);
  void take(std::vector<CommandReport>& out);

  /// Blocks until a reader of this link has data or timeout_s has passed; true if data.
  bool wait(double timeout_s);

  /// Readers of the measurement topic currently matched (for waiting on discovery).
  int matched_measurement_readers() const;
  int matched_command_readers() const;

  const SimLinkStats& stats() const { return stats_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  SimLinkStats stats_;
  int num_uavs_;
};

/// Checks of a received sample (used by SimLink; exposed for the tests): the reason it is
/// rejected, or nothing.
std::optional<std::string> check_clock(const ClockTick& c, int num_uavs);
std::optional<std::string> check_measurement(const Measurement& m, int num_uavs);
std::optional<std::string> check_command(const CommandReport& c, int num_uavs);

}  // namespace ridgeline::transport_dds
