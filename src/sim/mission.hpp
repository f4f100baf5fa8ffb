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

#include "learning/ddpg.hpp"
#include "mission/mission_metrics.hpp"
#include "mission/scenario.hpp"
#include "planning/global_planner.hpp"
#include "sim/external_vehicles.hpp"
#include "sim/method.hpp"

namespace ridgeline::sim {

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

/// Flies the planned mission. `plan` must be planned (status kPlanned) for this scenario (a
/// UAV without a plan entry holds at its start);
/// throws InputError otherwise.
mission::MissionResult fly_mission(const mission::Scenario& scenario,
                                   std::shared_ptr<const world::Terrain> terrain,
                                   const planning::GlobalPlan& plan,
                                   const MissionOptions& options = {});

}  // namespace ridgeline::sim
