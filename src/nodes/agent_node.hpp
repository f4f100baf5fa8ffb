// `ridgeline agent --id I`: one UAV's on-board computer as a process (issue 7, part 2): the
// Agent (MPC tracker, threat and neighbour tables, local re-plan) unchanged, talking to the
// other UAVs only through the DDS Transport, to its sensors and flight controller through the
// world's measurement/command topics, and receiving its reference from the ground station.
//
// It waits for its plan (transient local: it may start late), announces itself (hello) until
// the world's first measurement arrives, then answers every measurement: deliver received
// messages, sense, control, broadcast its prediction, answer with the command. A newer plan
// version (the ground station re-allocated targets) rebuilds the agent on the new reference
// (the targets inspected so far stay counted). It exits when the world's clock stops.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "mission/scenario.hpp"
#include "swarm/transport.hpp"
#include "transport_dds/dds_participant.hpp"
#include "world/terrain.hpp"

namespace ridgeline::nodes {

struct AgentNodeOptions {
  int id = 0;
  double plan_timeout_s = 120.0;    ///< wall time to wait for the plan
  double silence_timeout_s = 60.0;  ///< wall time without a measurement before giving up
  swarm::LinkModel emulated_link;   ///< added to UAV-to-UAV messages on reception
  std::uint64_t seed = 1;           ///< of the emulated link
  /// Lock-step: wall time to wait for the neighbours' messages of the previous tick.
  double lock_step_wait_s = 0.5;
};

struct AgentNodeResult {
  long long steps = 0;
  int plan_version = -1;
  long long rejected = 0;            ///< messages refused by the agent, its transport and its links
  long long dropped = 0;             ///< by the emulated link
  long long lock_step_timeouts = 0;  ///< ticks computed without all neighbours' messages
  bool world_stopped = false;        ///< false: gave up (silence) — an error
  std::string message;
};

/// Throws InputError for an id outside the scenario's UAVs, std::runtime_error when no plan
/// arrives in time.
AgentNodeResult run_agent_node(const mission::Scenario& scenario,
                               std::shared_ptr<const world::Terrain> terrain,
                               const transport_dds::DdsOptions& dds,
                               const AgentNodeOptions& options);

}  // namespace ridgeline::nodes
