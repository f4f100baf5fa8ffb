// The closed-loop mission (issue "main job", parts 1–5): the truth world, one agent per UAV,
// the in-process transport between them, and the metrics.
//
// Time: the loop ticks at the message rate (100 Hz by default). At every tick the truth is
// integrated up to now (RK4 at truth_rate_hz), messages due are delivered, and every agent
// broadcasts its latest prediction. Every control period (50 Hz) each agent senses threats,
// reads its noisy position fix and anemometer, and computes its command, which the truth's
// flight controller holds until the next one (zero-order hold). Agents talk only through the
// transport. Deterministic for a scenario seed (one thread per mission).
//
// The mission ends when every agent is finished (targets inspected or declared missed) or at
// simulation.duration_s.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mpc/uav_tracker.hpp"
#include "planning/global_planner.hpp"
#include "sim/external_vehicles.hpp"
#include "sim/method.hpp"
#include "sim/mission_metrics.hpp"
#include "sim/scenario.hpp"
#include "baselines/baseline_agent.hpp"
#include "learning/ddpg.hpp"
#include "swarm/agent.hpp"

namespace ridgeline::sim {

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

struct MissionOptions {
  bool record_trajectories = true;
  /// Which on-board agents fly the plan (method.hpp); the plan must be that method's.
  Method method = Method::kProposed;
  /// The policy of Method::kDdpg (required for it; shared by every UAV and read only).
  std::shared_ptr<const learning::DdpgPolicy> ddpg_policy;
  /// Called about once per simulated second with (t, duration).
  std::function<void(double, double)> progress;
  /// When set, the UAVs fly in these vehicles (e.g. MAVLink vehicle processes) instead of the
  /// truth world's RK4; every control period each gets its UAV's command and reports its state
  /// (sim/external_vehicles.hpp). The truth's state is then the reported one, sampled at the
  /// control rate, with the airspeed v = (ground velocity − W)·(cos ψ, sin ψ) and w = v_z − W_z
  /// from the truth's wind W at the reported position. Not owned.
  ExternalVehicles* vehicles = nullptr;
};

struct MissionResult {
  MissionMetrics metrics;
  std::vector<TrajectoryRow> trajectories;
};

/// The tracker's options for a UAV from the scenario's mpc block and safety margins.
mpc::UavTrackerOptions make_tracker_options(const Scenario& scenario, const UavSpec& uav);

/// The agent's options for UAV `index` with its targets from the plan.
swarm::AgentOptions make_agent_options(const Scenario& scenario, int index,
                                       const planning::UavPlan& plan);

/// The comparison agents' options for UAV `index` (baselines/baseline_agent.hpp).
baselines::BaselineAgentOptions make_baseline_agent_options(const Scenario& scenario, int index,
                                                            const planning::UavPlan& plan);

/// Flies the planned mission. `plan` must be planned (status kPlanned) for this scenario (a
/// UAV without a plan entry holds at its start);
/// throws InputError otherwise.
MissionResult fly_mission(const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain,
                          const planning::GlobalPlan& plan, const MissionOptions& options = {});

/// trajectories.csv: header `t,uav,x,y,z,ref_x,ref_y,ref_z,v,psi,w`, uav by name.
std::string trajectories_csv(const std::vector<TrajectoryRow>& rows, const Scenario& scenario);

}  // namespace ridgeline::sim
