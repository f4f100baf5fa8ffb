// The one metrics recorder of a flown mission (DESIGN §6), fed by whichever loop flies it: the
// in-process mission (sim::fly_mission) and the DDS world node (nodes::run_world_node) call the
// same methods at the same points of their ticks, so `run` and `launch` measure alike and write
// the same metric keys.
//
// Everything is measured on the truth: path length, tracking error every 10 m of flown path,
// the constraint checks at control steps (altitude band, pitch, the commanded turn against
// eq. 3 at the current speed), the flown turn radius, and the per-tick distances of the
// SafetyTally (clearance, separation, threat encounters and intrusions).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "mission/mission_metrics.hpp"
#include "mission/safety_tally.hpp"
#include "mission/scenario.hpp"
#include "mission/truth_world.hpp"
#include "swarm/uav_agent.hpp"
#include "world/terrain.hpp"

namespace ridgeline::mission {

/// What a UAV's agent reported for one control step, after its command was applied.
struct ControlReport {
  bool finished = false;            ///< the agent is finished (its UAV holds)
  Vec3 reference_m = Vec3::Zero();  ///< r(t) at this step (the position if finished)
  vehicle::Input command = vehicle::Input::Zero();  ///< the command applied this period
  bool has_tracker = false;      ///< the MPC's timings below are valid (the proposed method)
  double mpc_step_us = 0.0;      ///< the tracker's step, wall clock
  double mpc_step_cpu_us = 0.0;  ///< the same in thread CPU time
  double qp_iterations = 0.0;
  double step_time_us = -1.0;  ///< a comparison method's step (no tracker); < 0: not timed
  double max_slack_m = 0.0;    ///< the largest soft-row slack of the step
};

/// What a UAV's agent says at the end of the mission.
struct UavOutcome {
  int targets_assigned = 0;
  int targets_inspected = 0;
  std::vector<std::string> missed_targets;
  bool finished = false;
  double finish_time_s = -1.0;  ///< < 0: never finished
  swarm::AgentCounters counters;
};

class FlightRecorder {
 public:
  /// Starts at the truth's current positions. `terrain` must outlive the recorder.
  FlightRecorder(const Scenario& scenario, const world::Terrain& terrain, const TruthWorld& world,
                 bool record_trajectories);

  /// UAV `uav`'s sensor saw threat `threat` at control tick t (an encounter).
  void sensed(int uav, int threat, double t, const TruthWorld& world);
  /// UAV `uav` at control tick t, after its command was applied.
  void control_step(int uav, double t_s, const TruthWorld& world, const ControlReport& report);
  /// A control tick at which UAV `uav` had no answer (agent not started, lost, or late): the
  /// truth still moves and is recorded, with no tracking sample and no command check.
  void unanswered(int uav, double t_s, const TruthWorld& world);
  /// The truth's distances of a message tick (after the truth was advanced to t).
  void tick(double t_s, const TruthWorld& world);

  /// The metrics at mission time t from every UAV's outcome (in scenario order). The timing
  /// and message-count fields (wall, CPU, messages) are the caller's to fill.
  MissionResult finish(double t_s, const std::vector<UavOutcome>& outcomes);

 private:
  struct UavTally {
    Vec3 last_position = Vec3::Zero();
    double path_m = 0.0;
    double next_sample_m = 0.0;
    double squared_error_sum = 0.0;
    int samples = 0;
    double max_slack_m = 0.0;
  };
  void path_and_constraints(int uav, double t_s, const TruthWorld& world, bool finished,
                            const Vec3* reference_m, const vehicle::Input* command);

  const Scenario& scenario_;
  bool record_;
  MissionResult result_;
  std::vector<UavTally> tally_;
  std::vector<double> step_us_, step_cpu_us_, iterations_;
  SafetyTally safety_;
  double min_turn_radius_m_;
};

}  // namespace ridgeline::mission
