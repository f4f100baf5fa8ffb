// The closed loop's speed: how much faster than real time the whole mission simulates.
// One plan, then `repeats` identical flights of it (the same seed, so the same work each
// time); the figures are medians over the flights, in wall-clock and in thread CPU time. On
// a shared machine the wall clock includes the time other processes held the core, so the
// CPU figure is the one that says what one core can do; both are reported.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "benchmarks/host_speed.hpp"
#include "mission/scenario.hpp"
#include "mission/statistics.hpp"
#include "planning/global_planner.hpp"
#include "world/terrain.hpp"

namespace ridgeline::benchmarks {

struct MissionBenchmarkOptions {
  int repeats = 5;  ///< identical flights; figures are their medians
};

/// One flight's figures.
struct MissionBenchmarkRun {
  double sim_time_s = 0.0;
  double wall_time_s = 0.0;
  double cpu_time_s = 0.0;
  bool safe = false;
  bool mission_complete = false;
  mission::Percentiles mpc_step_us;
  mission::Percentiles mpc_step_cpu_us;
};

struct MissionBenchmarkReport {
  int uavs = 0;
  std::vector<MissionBenchmarkRun> runs;
  double real_time_factor_wall = 0.0;  ///< simulated s / wall s, median over the flights
  double real_time_factor_cpu = 0.0;   ///< simulated s / thread CPU s, median over the flights
  double wall_time_s_median = 0.0;
  double cpu_time_s_median = 0.0;
  /// Every flight simulated the same time and ended in the same state (the loop is
  /// deterministic for a seed, so a difference is a bug, not noise).
  bool deterministic = true;
  HostSpeed host_speed;  ///< this core's speed before and after the flights
  /// This thread's interruptions, probed before the flights (kInterruptionProbeMs): time the
  /// host took from the core, which the CPU-time factor counts as the flights'.
  HostInterruptions host_interruptions;
  nlohmann::json to_json() const;
};

/// Flies `plan` (which must be planned) `options.repeats` times and reports the speed.
/// Throws InputError for repeats < 1 or a plan that is not planned.
MissionBenchmarkReport run_mission_benchmark(const mission::Scenario& scenario,
                                             std::shared_ptr<const world::Terrain> terrain,
                                             const planning::GlobalPlan& plan,
                                             const MissionBenchmarkOptions& options = {});

}  // namespace ridgeline::benchmarks
