// The messages of the world simulator's side channel over DDS (issue 7, part 2; sim_link.hpp):
// the shared clock, each UAV's measurements and the agents' answers. Defined once here; their
// IDL and DDS conversions are generated from the RIDGELINE_WIRE_FIELDS lists (as for the swarm's
// messages, messages/messages.hpp). No DDS type here: the IDL writer reads this header.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "messages/wire_fields.hpp"
#include "swarm/uav_agent.hpp"
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
RIDGELINE_WIRE_FIELDS(ClockTick, "Clock", tick, t_s, running, lock_step, lost, answered,
                      reports_sent, prediction_stamps)

/// What one UAV's sensors report at a tick.
struct Measurement {
  int uav = -1;
  std::uint64_t tick = 0;
  double t_s = 0.0;
  vehicle::State state = vehicle::State::Zero();
  Vec3 wind_m_s = Vec3::Zero();
  std::vector<swarm::ThreatObservation> threats;  ///< centres at t_s
};
RIDGELINE_WIRE_FIELDS(Measurement, "Measurement", uav, tick, t_s, state, wind_m_s, threats)

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
RIDGELINE_WIRE_FIELDS(CommandReport, "Command", uav, hello, tick, t_s, command, mode, reference_m,
                      has_tracker, mpc_step_us, mpc_step_cpu_us, qp_iterations, max_slack_m,
                      plan_version, targets_assigned, targets_inspected, missed_targets, counters,
                      prediction_stamp_s, loop_period_s, compute_s)

}  // namespace ridgeline::transport_dds
