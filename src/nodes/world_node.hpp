// `ridgeline world`: the truth simulator as a node of the distributed swarm (issue 7, part 2).
// It owns the truth (dynamics in the wind, threats, sensors), keeps the shared clock and, every
// control period (50 Hz), publishes each UAV's measurement (noisy state fix, anemometer,
// threats in sensor range); it applies the agents' answers (commands) to the truth and
// measures the mission (mission::FlightRecorder, the same recorder as `ridgeline run`).
//
// Lock-step (default): tick k+1 starts when every started, live agent has answered tick k —
// the mission runs as fast as the agents allow and each command is applied at the instant of
// its measurement, as in the in-process run. An agent that has not answered within
// answer_timeout_s of wall time is declared lost.
// Real time: ticks follow the wall clock at the control period; a command is applied when it
// arrives (the truth is advanced to that instant first); an answer that arrives after the
// next tick has started is a missed deadline; an agent silent for lost_after_periods
// consecutive periods is declared lost.
// A lost UAV's autopilot takes over (PX4's offboard-loss failsafe: hold position): the truth
// holds it, and the clock lists it in `lost` for the ground station. A UAV whose agent has
// not started yet holds at its start and is released (at rest) when its agent says hello.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mission/mission_metrics.hpp"
#include "mission/scenario.hpp"
#include "transport_dds/dds_participant.hpp"
#include "world/terrain.hpp"

namespace ridgeline::nodes {

struct WorldNodeOptions {
  bool lock_step = true;
  /// Agents to wait for before tick 0 (−1: every UAV's); the others may start late.
  int wait_for_agents = -1;
  double start_timeout_s = 600.0;  ///< wall time to wait for them (a big team plans long)
  double answer_timeout_s = 5.0;   ///< lock-step: wall time before a silent agent is lost
  int lost_after_periods = 25;     ///< real time: silent periods before an agent is lost
  bool record_trajectories = true;
  /// Called about once per simulated second with (t, duration).
  std::function<void(double, double)> progress;
};

/// Timing of one agent's loop as the world saw it and as the agent reported it.
struct AgentDeadlineStats {
  std::string name;
  long long answers = 0;
  double loop_period_mean_s = 0.0;     ///< agent's wall time between consecutive answers
  double loop_period_jitter_s = 0.0;   ///< standard deviation of that period
  double loop_period_max_dev_s = 0.0;  ///< max |period − control period| (real time)
  double compute_p50_s = 0.0;          ///< measurement taken → command written
  double compute_p99_s = 0.0;
  double compute_max_s = 0.0;
  double latency_p99_s = 0.0;      ///< world: measurement published → answer taken
  long long missed_deadlines = 0;  ///< answers later than one control period
  /// Real time: setpoints whose |ω_c| the flight controller held to the turn limit at the
  /// speed they landed at (always 0 in lock step, where a setpoint lands on its own state).
  long long turn_setpoints_limited = 0;
  double started_s = -1.0;  ///< mission time of its hello (−1: never)
  double lost_s = -1.0;     ///< mission time it was declared lost (−1: not lost)
};

struct WorldNodeResult {
  mission::MissionResult mission;
  std::vector<AgentDeadlineStats> agents;
  std::vector<int> lost;
  long long messages_rejected = 0;  ///< malformed answers the world refused
  std::string last_rejection;
  bool lock_step = true;
  double wall_time_s = 0.0;
};

/// Runs the world until every agent is finished or lost, or simulation.duration_s. Throws
/// InputError for invalid options.
WorldNodeResult run_world_node(const mission::Scenario& scenario,
                               std::shared_ptr<const world::Terrain> terrain,
                               const transport_dds::DdsOptions& dds,
                               const WorldNodeOptions& options);

}  // namespace ridgeline::nodes
