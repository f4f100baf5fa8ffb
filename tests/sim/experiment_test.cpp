// The comparison experiment (issue 6): experiment.json's shape, identical seeds for every
// method per (task, run), aggregates that agree with the per-run rows they summarize, results
// independent of the number of threads, and task targets placed on the terrain.
#include "sim/experiment.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "core/error.hpp"
#include "support/small_mission.hpp"
#include "world/terrain.hpp"

namespace ridgeline::sim {
namespace {

// The shared small scenario (tests/support) with short flights: the shape and the seeds are
// under test, not the missions.
mission::Scenario small_scenario(std::shared_ptr<const world::Terrain>& terrain) {
  mission::Scenario s = test::small_scenario(terrain, true);
  s.simulation.duration_s = 25.0;
  return s;
}

// The committed DDPG model (models/README.md), loaded once.
std::shared_ptr<const learning::DdpgPolicy> committed_policy() {
  static const auto policy = std::make_shared<const learning::DdpgPolicy>(
      learning::DdpgPolicy::load(RIDGELINE_SOURCE_DIR "/models/ddpg_mountain.pt"));
  return policy;
}

ExperimentOptions small_options(int threads) {
  ExperimentOptions o;
  o.ddpg_policy = committed_policy();
  o.runs = 2;
  o.threads = threads;
  o.tasks = {{"own", "the scenario's targets", {}}, {"corner", "one target", {{0.85, 0.85}}}};
  return o;
}

TEST(Experiment, JsonHasEveryTaskAndMethodWithIdenticalSeedsPerRun) {
  std::shared_ptr<const world::Terrain> terrain;
  const mission::Scenario s = small_scenario(terrain);
  const nlohmann::json e = run_experiment(s, terrain, small_options(2));
  ASSERT_EQ(e.at("tasks").size(), 2u);
  EXPECT_EQ(e.at("tasks")[0].at("task"), "own");
  EXPECT_EQ(e.at("tasks")[1].at("task"), "corner");
  std::set<std::uint64_t> all_seeds;
  for (const nlohmann::json& task : e.at("tasks")) {
    const nlohmann::json& seeds = task.at("seeds");
    ASSERT_EQ(seeds.size(), 2u);
    EXPECT_NE(seeds[0], seeds[1]);  // runs differ
    for (const auto& seed : seeds) all_seeds.insert(seed.get<std::uint64_t>());
    ASSERT_EQ(task.at("methods").size(), 4u);
    for (const char* name : {"proposed", "astar_dwa", "wind_aware", "ddpg"}) {
      ASSERT_TRUE(task.at("methods").contains(name)) << name;
      const nlohmann::json& M = task.at("methods").at(name);
      EXPECT_EQ(M.at("plan_status"), "planned") << M.at("plan_message");
      for (const char* key :
           {"path_length_m", "avoidance_success_rate", "tracking_mse_m2",
            "tracking_mse_by_distance", "collisions", "plan_time_s", "control_step_us"})
        EXPECT_TRUE(M.contains(key)) << name << " " << key;
      // Identical seeds per (task, run) for every method.
      const nlohmann::json& runs = M.at("runs");
      ASSERT_EQ(runs.size(), 2u);
      double sum = 0.0, sum2 = 0.0;
      for (std::size_t r = 0; r < 2; ++r) {
        EXPECT_EQ(runs[r].at("seed"), seeds[r]) << name;
        ASSERT_FALSE(runs[r].contains("error")) << runs[r].at("error");
        const double p = runs[r].at("path_length_m").get<double>();
        EXPECT_GT(p, 0.0);
        sum += p;
        sum2 += p * p;
      }
      // The aggregate is the mean and sample standard deviation of the rows (1e-9 relative:
      // two summation orders).
      const double mean = sum / 2.0;
      const double sd = std::sqrt(std::max(0.0, (sum2 - 2.0 * mean * mean) / 1.0));
      EXPECT_NEAR(M.at("path_length_m").at("mean").get<double>(), mean, 1e-9 * mean);
      EXPECT_NEAR(M.at("path_length_m").at("std").get<double>(), sd, 1e-6 * mean);
      const double rate = M.at("avoidance_success_rate").get<double>();
      EXPECT_GE(rate, 0.0);
      EXPECT_LE(rate, 1.0);
      const nlohmann::json& d = M.at("tracking_mse_by_distance");
      EXPECT_EQ(d.at("distance_m").size(), d.at("mse_m2").size());
      EXPECT_FALSE(d.at("distance_m").empty());
    }
  }
  // Run r is the same variation of threats, wind, noise and starts in every task too.
  EXPECT_EQ(all_seeds.size(), 2u);
  // The task target sits target_height_m above the terrain at 85 % of the area.
  const auto& corner = e.at("tasks")[1].at("targets")[0].at("position_m");
  EXPECT_NEAR(corner[0].get<double>(), 680.0, 1e-9);
  EXPECT_NEAR(corner[2].get<double>(), terrain->height(680, 680) + 60.0, 1e-9);
}

TEST(Experiment, ResultsDoNotDependOnTheNumberOfThreads) {
  std::shared_ptr<const world::Terrain> terrain;
  mission::Scenario s = small_scenario(terrain);
  s.simulation.duration_s = 15.0;
  ExperimentOptions o = small_options(1);
  o.tasks.resize(1);
  const nlohmann::json a = run_experiment(s, terrain, o);
  o.threads = 2;
  const nlohmann::json b = run_experiment(s, terrain, o);
  // ddpg too: the one policy is shared read-only by the threads' flights.
  for (const char* name : {"proposed", "astar_dwa", "wind_aware", "ddpg"}) {
    const auto& ra = a["tasks"][0]["methods"][name]["runs"];
    const auto& rb = b["tasks"][0]["methods"][name]["runs"];
    for (std::size_t r = 0; r < 2; ++r) {
      EXPECT_EQ(ra[r]["path_length_m"], rb[r]["path_length_m"]) << name;
      EXPECT_EQ(ra[r]["tracking_mse_m2"], rb[r]["tracking_mse_m2"]) << name;
    }
  }
}

TEST(Experiment, BadOptionsAndTargetsOutsideTheAreaAreClearErrors) {
  std::shared_ptr<const world::Terrain> terrain;
  const mission::Scenario s = small_scenario(terrain);
  ExperimentOptions o = small_options(1);
  o.runs = 0;
  EXPECT_THROW(run_experiment(s, terrain, o), InputError);
  o = small_options(1);
  o.ddpg_policy = nullptr;
  try {
    run_experiment(s, terrain, o);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "--ddpg-model");
  }
  o = small_options(1);
  o.tasks = {{"bad", "", {{1.5, 0.5}}}};
  try {
    run_experiment(s, terrain, o);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tasks.bad.targets[0]"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ridgeline::sim
