// Monte Carlo batches of the closed-loop mission (issue "main job", part 7): one plan, many
// flights, each a variation (variation.hpp) with its own seed, run on a pool of threads. Each
// flight is deterministic for its seed, so the batch's results do not depend on the number of
// threads, and a failed run is replayed with `ridgeline run --variation SEED`.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "learning/ddpg.hpp"
#include "mission/mission_metrics.hpp"
#include "mission/scenario.hpp"
#include "planning/global_planner.hpp"
#include "sim/method.hpp"
#include "sim/variation.hpp"

namespace ridgeline::sim {

struct MonteCarloOptions {
  int runs = 100;
  int threads = 1;
  VariationOptions variation;
  Method method = Method::kProposed;  ///< the agents that fly; the plan must be this method's
  std::shared_ptr<const learning::DdpgPolicy> ddpg_policy;  ///< required for Method::kDdpg
  /// Called from the worker threads (serialized) after each run: (done, total, failed so far).
  std::function<void(int, int, int)> progress;
};

struct MonteCarloRun {
  int index = 0;
  std::uint64_t seed = 0;
  mission::MissionMetrics metrics;
  /// Why the run failed: "terrain collision", "threat intrusion", ...; empty when it passed.
  std::vector<std::string> failures;
};

struct MonteCarloReport {
  std::vector<MonteCarloRun> runs;  ///< in index order
  int threads = 1;
  double wall_time_s = 0.0;

  /// Counts, rates with Wilson 95 % intervals, each metric's distribution, failed runs.
  nlohmann::json summary() const;
};

/// Throws InputError for runs < 1 or threads < 1, or a plan that is not planned.
MonteCarloReport run_monte_carlo(const mission::Scenario& scenario,
                                 std::shared_ptr<const world::Terrain> terrain,
                                 const planning::GlobalPlan& plan,
                                 const MonteCarloOptions& options);

}  // namespace ridgeline::sim
