// The swarm benchmark of the field (issue 19 part 3), over terrain: circle swaps. N UAVs start
// evenly on a horizontal circle above the terrain, each heading for its antipode, so that all
// of them cross the centre together. Their references are the straight lines at cruise speed,
// not deconflicted by the ground station: whatever keeps them apart is the on-board protocol
// (agents, predictions over the lossy, delayed link, the MPC), which is what is measured.
//
// Each cell (team size × link latency, with a loss rate) flies `runs` seeded variations
// (sim/variation.hpp: starts ±5 m and ±10°, another wind gust realisation and direction,
// another sensor noise) through the same closed loop as `ridgeline run`, and reports as
// RMADER's table does: the collision-free rate (d_safe never broken on the truth, every
// simulation step), the completion rate (every UAV at its antipode), the mean completion time
// against the straight-line bound 2R / v_max, and the hard constraint violations. A run that
// breaks separation is listed with its seed and its closest approach.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "mission/mission_metrics.hpp"
#include "mission/scenario.hpp"
#include "planning/global_planner.hpp"
#include "world/terrain.hpp"

namespace ridgeline::benchmarks {

struct CircleSwapOptions {
  int uavs = 8;
  double radius_m = 250.0;
  /// Flight altitude above the highest terrain under the circle (plus its h_safe).
  double altitude_above_terrain_m = 30.0;
};

/// The circle swap on `base`'s terrain, area, wind, limits and layers: no targets, no threats;
/// UAV i starts at angle 2πi/N around the area's centre facing it and ends at the antipode.
/// Throws InputError naming the option when the circle does not fit the area, its starts are
/// closer than d_safe + 5 m, or the flight altitude leaves the altitude band.
mission::Scenario make_circle_swap(const mission::Scenario& base, const world::Terrain& terrain,
                                   const CircleSwapOptions& options);

/// Every UAV's straight line from its start to its end at cruise speed, time-parametrized and
/// checked against the terrain (status kPlanned), and deliberately not against each other.
planning::GlobalPlan straight_line_plan(const mission::Scenario& swap,
                                        std::shared_ptr<const world::Terrain> terrain);

struct SwarmBenchmarkOptions {
  std::vector<int> team_sizes = {8, 16, 32};
  std::vector<double> latencies_s = {0.0, 0.1, 0.3};
  double loss_rate = 0.2;
  int runs = 100;
  int threads = 2;
  double radius_m = 250.0;
  /// Called after each run: (cell label, done, total, failed so far in the cell).
  std::function<void(const std::string&, int, int, int)> progress;
};

struct SwarmFailedRun {
  int index = 0;
  std::uint64_t seed = 0;
  double min_separation_m = 0.0;
  std::pair<int, int> closest_pair{-1, -1};  ///< the UAVs of the closest approach
  double closest_time_s = 0.0;
  std::vector<std::string> reasons;
};

struct SwarmCell {
  int uavs = 0;
  double latency_s = 0.0;
  double loss_rate = 0.0;
  int runs = 0;
  int collision_free = 0;  ///< runs where no pair came closer than d_safe on the truth
  int completed = 0;       ///< runs where every UAV reached its antipode
  int constraint_violations = 0;  ///< control steps breaking a hard limit, over all runs
  int terrain_collisions = 0;
  double min_separation_m = 0.0;         ///< the closest approach over all runs
  double mean_completion_time_s = 0.0;   ///< over completed runs (NaN without one)
  double straight_line_bound_s = 0.0;    ///< 2R / v_max
  double cpu_time_s = 0.0;               ///< the flights' own CPU time
  double wall_time_s = 0.0;
  std::vector<SwarmFailedRun> failed;    ///< every run that was not collision-free and complete
};

struct SwarmBenchmarkReport {
  double d_safe_m = 0.0;
  double radius_m = 0.0;
  std::vector<SwarmCell> cells;
  nlohmann::json to_json() const;
  /// The table as Markdown (the README's), one row per cell.
  std::string to_markdown() const;
};

/// One run of a cell again (its seed from the cell's failed_runs), with trajectories: the
/// swap of `uavs` on `base`'s terrain, the link at `latency_s` and `loss_rate`.
mission::MissionResult replay_swarm_run(const mission::Scenario& base,
                                        std::shared_ptr<const world::Terrain> terrain, int uavs,
                                        double radius_m, double latency_s, double loss_rate,
                                        std::uint64_t seed, mission::Scenario* flown = nullptr);

/// Runs every cell on `base`'s terrain. Throws InputError for runs < 1, threads < 1, an empty
/// or non-positive team size, a negative or non-finite latency, or a loss rate outside [0, 1).
SwarmBenchmarkReport run_swarm_benchmark(const mission::Scenario& base,
                                         std::shared_ptr<const world::Terrain> terrain,
                                         const SwarmBenchmarkOptions& options);

}  // namespace ridgeline::benchmarks
