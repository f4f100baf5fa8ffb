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

#include "core/types.hpp"
#include "swarm/agent.hpp"
#include "transport_dds/dds_participant.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::transport_dds {

/// The world's clock: tick k is mission time t_s = k·control period.
struct ClockTick {
  std::uint64_t tick = 0;
  double t_s = 0.0;
  bool running = true;    ///< false once: the mission is over, every node exits
  bool lock_step = true;  ///< false in real time
  std::vector<int> lost;  ///< UAVs whose agent the world declared lost
  /// UAVs that answered the previous tick, and the threat reports each had sent by then.
  std::vector<int> answered;
  std::vector<std::int64_t> reports_sent;
  std::vector<double> prediction_stamps;  ///< of the prediction each published with its answer
};

/// What one UAV's sensors report at a tick.
struct Measurement {
  int uav = -1;
  std::uint64_t tick = 0;
  double t_s = 0.0;
  vehicle::State state = vehicle::State::Zero();
  Vec3 wind_m_s = Vec3::Zero();
  std::vector<swarm::ThreatObservation> threats;
};

/// An agent's answer to the Measurement of `tick` (or, with hello, its announcement).
struct CommandReport {
  int uav = -1;
  bool hello = false;
  std::uint64_t tick = 0;
  double t_s = 0.0;
  vehicle::Input command = vehicle::Input::Zero();
  swarm::AgentMode mode = swarm::AgentMode::kTracking;
  Vec3 reference_m = Vec3::Zero();
  bool has_tracker = false;
  double mpc_step_us = 0.0;
  double mpc_step_cpu_us = 0.0;
  double qp_iterations = 0.0;
  double max_slack_m = 0.0;
  int plan_version = 0;
  int targets_assigned = 0;
  int targets_inspected = 0;
  std::vector<std::string> missed_targets;
  swarm::AgentCounters counters;
  double prediction_stamp_s = 0.0;  ///< stamp of the prediction published before the answer
  double loop_period_s = 0.0;       ///< agent's wall time between this and its previous answer
  double compute_s = 0.0;           ///< agent's wall time from Measurement taken to answer written
};

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
std::optional<std::string> check_measurement(const Measurement& m, int num_uavs);
std::optional<std::string> check_command(const CommandReport& c, int num_uavs);

}  // namespace ridgeline::transport_dds
