// What a flown mission is judged by (DESIGN §6, issue "main job" part 5). Everything here is
// measured on the truth (true positions, the threats' true motion), never on what the agents
// believe.
#pragma once

#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "core/types.hpp"
#include "mission/scenario.hpp"
#include "mission/statistics.hpp"

namespace ridgeline::mission {

struct UavMetrics {
  std::string name;
  double path_length_m = 0.0;
  /// Reference (what the agent tracked, including its local re-plans) against the actual
  /// position at equal times, sampled every 10 m of flown path.
  double tracking_rmse_m = 0.0;
  double tracking_mse_m2 = 0.0;
  int tracking_samples = 0;
  double min_terrain_clearance_m = 0.0;
  int targets_assigned = 0;
  int targets_inspected = 0;
  std::vector<std::string> missed_targets;
  bool finished = false;
  double finish_time_s = -1.0;
  /// With an end position (uavs[i].end): the truth's final distance to it, and whether that is
  /// within the inspection radius a target would need (a mission with ends is complete only
  /// when every UAV is there). NaN / false without an end (JSON null).
  double end_distance_m = std::numeric_limits<double>::quiet_NaN();
  bool end_reached = false;
  // The agent's own counters.
  long long replans = 0;
  long long optimizer_replans = 0;    ///< of replans, made by the local optimizer
  long long neighbour_conflicts = 0;  ///< re-plans that yielded to a neighbour
  long long replan_failures = 0;
  long long rejoins = 0;
  long long level_changes = 0;  ///< separation levels the agent chose (swarm/agent.hpp)
  long long delay_changes = 0;  ///< separation delays the agent chose (swarm/agent.hpp)
  long long reapproaches = 0;   ///< blocked targets approached again (swarm/agent.hpp)
  long long guard_steps = 0;    ///< steps flown on the separation guard's escape command
  long long fallback_steps = 0;
  long long qp_failures = 0;
  long long stale_neighbour_steps = 0;
  long long messages_rejected = 0;
  double max_slack_m = 0.0;
};

struct MissionMetrics {
  std::vector<UavMetrics> uavs;
  double min_separation_m = 0.0;        ///< over pairs and time; +inf for one UAV (→ null)
  std::pair<int, int> min_separation_pair{-1, -1};  ///< the UAVs (indices) of that approach
  double min_separation_time_s = 0.0;               ///< and when it happened
  double min_threat_distance_m = 0.0;   ///< to the threat surface; +inf without threats
  int threat_encounters = 0;            ///< (UAV, threat) pairs where the UAV sensed it
  int threat_intrusions = 0;            ///< (UAV, threat) pairs that ever were inside it
  /// Of the intrusions, those no command within the limits could have avoided when the UAV
  /// first sensed the threat (threat_escape.hpp), with the straight-line time to contact at
  /// that moment; the rest are avoidable (the product's fault; must be 0).
  int unavoidable_intrusions = 0;
  int avoidable_intrusions = 0;
  std::vector<double> unavoidable_intrusion_contact_s;
  int threat_margin_violations = 0;     ///< pairs that came inside R + r_safe (not a collision)
  double avoidance_success_rate = 1.0;  ///< (encounters − intrusions)/encounters; 1 if none
  int terrain_collisions = 0;           ///< UAVs that ever were below the terrain
  int separation_violations = 0;        ///< pairs that ever came closer than d_safe
  std::map<std::string, int> constraint_violations;  ///< control steps per kind
  /// Flown turn radius v/|ω| at its smallest (the truth, lags included) and the largest
  /// ratio of the commanded |ω_c| to its limit v/R_min at the true speed when it was issued.
  double min_turn_radius_m = 0.0;
  double max_turn_command_ratio = 0.0;
  Percentiles mpc_solve_us;      ///< the whole MPC step (linearize, build, solve)
  Percentiles mpc_solve_cpu_us;  ///< the same steps in thread CPU time (no preemption)
  Percentiles qp_iterations;
  double global_plan_s = 0.0;
  double sim_time_s = 0.0;
  double wall_time_s = 0.0;
  /// The flight's CPU time on its thread: the closed loop's cost on one core, which a shared
  /// machine's wall clock overstates by the time other processes held the core.
  double cpu_time_s = 0.0;
  bool mission_complete = false;  ///< every UAV finished with every target inspected
  long long messages_published = 0;
  long long messages_dropped = 0;

  /// Zero terrain collisions, threat intrusions, separation and hard constraint violations.
  bool safe() const;
  int total_constraint_violations() const;
};

nlohmann::json to_json(const MissionMetrics& metrics);

/// One row of trajectories.csv: a UAV at a control step.
struct TrajectoryRow {
  double t_s = 0.0;
  int uav = 0;
  Vec3 position_m = Vec3::Zero();
  Vec3 reference_m = Vec3::Zero();
  double speed_m_s = 0.0;
  double heading_rad = 0.0;
  double climb_rate_m_s = 0.0;
};

struct MissionResult {
  MissionMetrics metrics;
  std::vector<TrajectoryRow> trajectories;
};

/// trajectories.csv: header `t,uav,x,y,z,ref_x,ref_y,ref_z,v,psi,w`, uav by name.
std::string trajectories_csv(const std::vector<TrajectoryRow>& rows, const Scenario& scenario);

}  // namespace ridgeline::mission
