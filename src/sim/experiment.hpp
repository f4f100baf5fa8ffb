// The paper's comparison experiment (§3, Figures 3–5; issue 6 part 4): several inspection
// tasks on one terrain, each flown by every method (method.hpp) in `runs` Monte Carlo
// variations. Run r of a task uses the same variation seed (variation.hpp) for every method,
// so all methods meet the same threats, wind, sensor noise and start jitter. Each method plans
// its task once (its own planner), as the ground station would before take-off.
//
// Tasks (default_experiment_tasks): target sets given as fractions of the scenario's area, at
// target_height_m above the terrain (clamped into the altitude band), so the same tasks apply
// to any terrain the scenario names:
//   northeast  — the scenario's own targets (the default: three dispersed in the north-east);
//   east       — (0.90, 0.35), (0.75, 0.65), (0.55, 0.95): up the eastern side;
//   crossing   — (0.15, 0.90), (0.50, 0.55), (0.95, 0.60): across the middle of the area;
//   far_corner — (0.92, 0.92): one far target for the whole team to share.
// Threats, wind and starts are the scenario's (varied per run).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "learning/ddpg.hpp"
#include "mission/scenario.hpp"
#include "sim/method.hpp"
#include "sim/variation.hpp"

namespace ridgeline::sim {

struct ExperimentTask {
  std::string name;
  std::string description;
  /// Targets as (x, y) fractions of the area; empty: the scenario's own targets.
  std::vector<Vec2> target_fractions;
};

std::vector<ExperimentTask> default_experiment_tasks();

struct ExperimentOptions {
  int runs = 10;
  int threads = 1;
  std::vector<ExperimentTask> tasks = default_experiment_tasks();
  std::vector<Method> methods = all_methods();
  /// The policy of Method::kDdpg: required when `methods` holds it (shared by every flight).
  std::shared_ptr<const learning::DdpgPolicy> ddpg_policy;
  VariationOptions variation;
  double target_height_m = 60.0;  ///< above the terrain, for targets given as fractions
  double error_bin_m = 100.0;     ///< distance bin of tracking_mse_by_distance
  /// Called (serialized) after each flight: (done, total, "task/method/run").
  std::function<void(int, int, const std::string&)> progress;
};

/// The scenario of one task: the base scenario with the task's targets. Throws InputError
/// when a target falls outside what the scenario allows (names the task and target).
mission::Scenario task_scenario(const mission::Scenario& base, const world::Terrain& terrain,
                                const ExperimentTask& task, double target_height_m);

/// Runs the experiment and returns experiment.json:
/// {"runs", "threads", "wall_time_s", "methods": [...], "tasks": [{"task", "description",
///  "targets": [...], "seeds": [...], "methods": {"proposed": M, "astar_dwa": M,
///  "wind_aware": M}}]} with M = {"plan_status", "plan_message", "plan_time_s",
///  "path_length_m": {mean, std} (team total per run), "path_length_per_uav_m": {mean, std},
///  "avoidance_success_rate", "threat_encounters", "threat_intrusions", "tracking_mse_m2":
///  {mean, std} (per UAV and run), "tracking_mse_by_distance": {"distance_m": [...],
///  "mse_m2": [...]}, "collisions": {terrain, threat, separation}, "constraint_violations",
///  "missions_complete", "control_step_us": {median, p99, max}, "wall_time_s", "runs":
///  [{seed, path_length_m, tracking_mse_m2, encounters, intrusions, ...}]}.
/// Throws InputError for runs < 1, threads < 1, no tasks or no methods, or ddpg without a policy.
nlohmann::json run_experiment(const mission::Scenario& base,
                              std::shared_ptr<const world::Terrain> terrain,
                              const ExperimentOptions& options);

}  // namespace ridgeline::sim
