// What the world node measures of a mission flown by agents in other processes: the same
// metrics as sim::fly_mission (MissionMetrics, trajectories.csv rows), taken on the truth, fed
// with what the agents report in their answers instead of reading their memory.
//
// The per-UAV measurements mirror fly_mission's (tracking error every 10 m of flown path,
// constraint checks at control steps); the per-tick distances (clearance, separation, threat
// encounters and intrusions) are the same sim::SafetyTally; a UAV whose agent was lost is
// counted as not finished.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sim/mission.hpp"
#include "sim/safety_tally.hpp"
#include "sim/scenario.hpp"
#include "sim/truth_world.hpp"
#include "transport_dds/sim_link.hpp"

namespace ridgeline::nodes {

class MissionRecorder {
 public:
  MissionRecorder(const sim::Scenario& scenario, std::shared_ptr<const world::Terrain> terrain,
                  const sim::TruthWorld& world, bool record_trajectories);

  /// UAV i's sensor saw threat k at a control tick (an encounter).
  void sensed(int uav, int threat);
  /// UAV i's agent answered the control tick at t (after the command was applied).
  void answered(int uav, double t_s, const transport_dds::CommandReport& answer,
                const sim::TruthWorld& world);
  /// A control tick at which UAV i had no answer (agent not started, lost, or late): the
  /// truth still moves and is recorded.
  void unanswered(int uav, double t_s, const sim::TruthWorld& world);
  /// Distances of every tick (after the truth was advanced to t).
  void tick(double t_s, const sim::TruthWorld& world);

  /// The metrics at the end; `last` holds each UAV's last answer (hello-only if none).
  sim::MissionResult finish(double t_s, const std::vector<transport_dds::CommandReport>& last,
                            const std::vector<double>& finish_time_s);

 private:
  struct UavTally {
    Vec3 last_position = Vec3::Zero();
    double path_m = 0.0;
    double next_sample_m = 0.0;
    double squared_error_sum = 0.0;
    int samples = 0;
    double max_slack_m = 0.0;
  };
  void path_and_constraints(int uav, double t_s, const sim::TruthWorld& world, bool finished,
                            const Vec3& reference_m, const vehicle::Input* command);

  const sim::Scenario& scenario_;
  std::shared_ptr<const world::Terrain> terrain_;
  bool record_;
  sim::MissionResult result_;
  std::vector<UavTally> tally_;
  std::vector<double> step_us_, iterations_;
  sim::SafetyTally safety_;
  double min_turn_radius_;
};

}  // namespace ridgeline::nodes
