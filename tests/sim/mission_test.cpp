// The closed-loop mission on small scenarios built in code: it completes, is safe, is
// deterministic for a seed, and its metrics measure what they say.
#include "sim/mission.hpp"

#include <gtest/gtest.h>

#include "mission/stage_inputs.hpp"
#include "mission/statistics.hpp"
#include "sim/monte_carlo.hpp"
#include "support/small_mission.hpp"
#include "world/terrain.hpp"

namespace ridgeline::sim {
namespace {

using test::Fixture;
using test::small_mission;

TEST(Mission, SmallMissionCompletesSafelyWithAThreatAndLossyLinks) {
  const Fixture f = small_mission(true);
  const mission::MissionResult r = fly_mission(f.scenario, f.terrain, f.plan);
  const mission::MissionMetrics& m = r.metrics;
  EXPECT_TRUE(m.mission_complete);
  EXPECT_TRUE(m.safe()) << to_json(m).dump(2);
  EXPECT_GE(m.min_separation_m, f.scenario.safety.separation_m);
  EXPECT_GT(m.threat_encounters, 0);
  EXPECT_EQ(m.threat_intrusions, 0);
  EXPECT_GT(m.messages_dropped, 0);  // 5 % of the copies are lost
  ASSERT_EQ(m.uavs.size(), 2u);
  for (const mission::UavMetrics& u : m.uavs) {
    EXPECT_EQ(u.targets_inspected, 1);
    EXPECT_GE(u.min_terrain_clearance_m, f.scenario.safety.terrain_clearance_m);
    EXPECT_LT(u.tracking_rmse_m, 5.0);
    EXPECT_GT(u.tracking_samples, 40);  // every 10 m of ≥ 600 m
  }
  // One row per UAV per control step until the last UAV finished.
  const int steps = static_cast<int>(std::round(m.sim_time_s / f.scenario.mpc.control_period_s));
  EXPECT_NEAR(static_cast<double>(r.trajectories.size()), 2.0 * steps, 4.0);
}

TEST(Mission, OptimizerReplanFromTheScenarioFliesSafely) {
  // planner.optimizer_replan reaches the agents: with the threat crossing the routes, at least
  // one conflict is re-planned by the local optimizer, and the flight is safe and complete.
  Fixture f = small_mission(true);
  f.scenario.planner.optimizer_replan = true;
  const mission::MissionResult r = fly_mission(f.scenario, f.terrain, f.plan);
  const mission::MissionMetrics& m = r.metrics;
  EXPECT_TRUE(m.mission_complete);
  EXPECT_TRUE(m.safe()) << to_json(m).dump(2);
  EXPECT_EQ(m.threat_intrusions, 0);
  EXPECT_GE(m.min_separation_m, f.scenario.safety.separation_m);
  long long optimizer_replans = 0;
  for (const mission::UavMetrics& u : m.uavs) {
    EXPECT_GE(u.min_terrain_clearance_m, f.scenario.safety.terrain_clearance_m);
    EXPECT_LE(u.optimizer_replans, u.replans);
    optimizer_replans += u.optimizer_replans;
  }
  EXPECT_GT(optimizer_replans, 0) << to_json(m).dump(2);
}

TEST(Mission, SameSeedGivesTheSameFlightAndAnotherSeedAnother) {
  Fixture f = small_mission(false);
  f.scenario.simulation.duration_s = 40.0;
  const mission::MissionResult a = fly_mission(f.scenario, f.terrain, f.plan);
  const mission::MissionResult b = fly_mission(f.scenario, f.terrain, f.plan);
  ASSERT_EQ(a.trajectories.size(), b.trajectories.size());
  for (std::size_t k = 0; k < a.trajectories.size(); k += 97)
    EXPECT_EQ(a.trajectories[k].position_m, b.trajectories[k].position_m) << k;
  mission::Scenario other = f.scenario;
  other.seed = 8;
  const mission::MissionResult c = fly_mission(other, f.terrain, f.plan);
  EXPECT_NE(a.trajectories[500].position_m, c.trajectories[500].position_m);
}

TEST(Mission, PerUavMissionsKeepRequiredTargetsAndEndWhereTheyAreSent) {
  // u0 must inspect both targets and come home; u1 has no target but a landing point.
  std::shared_ptr<const world::Terrain> terrain;
  mission::Scenario s = test::small_scenario(terrain, false);
  s.uavs[0].assigned_targets = {"b", "a"};
  s.uavs[0].end_position_m = s.uavs[0].start_position_m;
  s.uavs[1].end_position_m = Vec3(300, 120, 70);
  s.simulation.duration_s = 400.0;
  ASSERT_TRUE(validate(s, *terrain).empty());
  const planning::GlobalPlan plan = planning::plan_mission(
      mission::make_planning_problem(s, terrain), mission::make_planner_options(s));
  ASSERT_EQ(plan.status, planning::GlobalPlanStatus::kPlanned) << plan.message;
  ASSERT_EQ(plan.uavs.size(), 2u);  // u1 flies to its end although it has no target
  for (const planning::UavPlan& up : plan.uavs) {
    const int i = up.name == "u0" ? 0 : 1;
    EXPECT_EQ(up.targets.size(), i == 0 ? 2u : 0u) << up.name;
    // The path ends exactly at the end (a fixed point), and so does the reference.
    EXPECT_LT((up.waypoints_m.back() - *s.uavs[static_cast<std::size_t>(i)].end_position_m).norm(),
              1e-6)
        << up.name;
    EXPECT_LT(
        (up.timing.samples.back().position_m - *s.uavs[static_cast<std::size_t>(i)].end_position_m)
            .norm(),
        1e-3);
  }
  const mission::MissionResult r = fly_mission(s, terrain, plan);
  const mission::MissionMetrics& m = r.metrics;
  EXPECT_TRUE(m.safe()) << to_json(m).dump(2);
  EXPECT_TRUE(m.mission_complete) << to_json(m).dump(2);
  ASSERT_EQ(m.uavs.size(), 2u);
  EXPECT_EQ(m.uavs[0].targets_assigned, 2);
  EXPECT_EQ(m.uavs[0].targets_inspected, 2);
  for (const mission::UavMetrics& u : m.uavs) {
    EXPECT_TRUE(u.end_reached) << u.name;
    // It finished at the end of its reference, within tracking error of the end.
    EXPECT_LT(u.end_distance_m, 10.0) << u.name;
  }
  // Without the end, u0 would have finished at its last target, 700 m from home.
  EXPECT_GT(m.uavs[0].path_length_m, 1400.0);
}

TEST(Mission, UnplannedPlanIsRejectedWithTheField) {
  const Fixture f = small_mission(false);
  planning::GlobalPlan bad = f.plan;
  bad.status = planning::GlobalPlanStatus::kValidationFailed;
  try {
    fly_mission(f.scenario, f.terrain, bad);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "plan");
  }
}

TEST(MonteCarlo, ResultsDoNotDependOnTheNumberOfThreads) {
  Fixture f = small_mission(true);
  f.scenario.simulation.duration_s = 30.0;  // a partial flight is enough to compare
  MonteCarloOptions one;
  one.runs = 3;
  one.threads = 1;
  MonteCarloOptions two = one;
  two.threads = 2;
  const MonteCarloReport a = run_monte_carlo(f.scenario, f.terrain, f.plan, one);
  const MonteCarloReport b = run_monte_carlo(f.scenario, f.terrain, f.plan, two);
  ASSERT_EQ(a.runs.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(a.runs[k].seed, b.runs[k].seed);
    EXPECT_DOUBLE_EQ(a.runs[k].metrics.min_separation_m, b.runs[k].metrics.min_separation_m);
    EXPECT_DOUBLE_EQ(a.runs[k].metrics.uavs[0].path_length_m,
                     b.runs[k].metrics.uavs[0].path_length_m);
  }
  EXPECT_NE(a.runs[0].metrics.uavs[0].path_length_m, a.runs[1].metrics.uavs[0].path_length_m);
  // 30 s is too short to finish: every run is listed as failed, with its seed.
  const nlohmann::json s = a.summary();
  EXPECT_EQ(s["runs"].get<int>(), 3);
  EXPECT_EQ(s["failed_runs"].size(), 3u);
  EXPECT_EQ(s["failed_runs"][0]["seed"].get<std::uint64_t>(), a.runs[0].seed);
  EXPECT_EQ(s["counts"]["complete_missions"].get<int>(), 0);
  // The CPU figures add the flights' own thread CPU times; one thread's CPU time never
  // exceeds the wall time of its flight (10 ms per flight for the clocks' granularities).
  double cpu = 0.0, wall = 0.0;
  for (const MonteCarloRun& r : a.runs) {
    EXPECT_GT(r.metrics.cpu_time_s, 0.0);
    cpu += r.metrics.cpu_time_s;
    wall += r.metrics.wall_time_s;
  }
  EXPECT_NEAR(s["flight_cpu_time_s"].get<double>(), cpu, 1e-9);
  EXPECT_LE(cpu, wall + 0.03);
  EXPECT_NEAR(s["runs_per_cpu_second"].get<double>(), 3.0 / cpu, 1e-9);
}

TEST(Statistics, WilsonIntervalsMatchTheFormula) {
  const mission::Interval none = mission::wilson_interval(0, 10);
  EXPECT_NEAR(none.low, 0.0, 1e-12);
  EXPECT_NEAR(none.high, 0.2775, 1e-4);
  const mission::Interval half = mission::wilson_interval(5, 10);
  EXPECT_NEAR(half.low, 0.2366, 1e-4);
  EXPECT_NEAR(half.high, 0.7634, 1e-4);
  const mission::Interval all = mission::wilson_interval(200, 200);
  EXPECT_NEAR(all.low, 0.9812, 1e-4);
  EXPECT_NEAR(all.high, 1.0, 1e-12);
  const mission::Percentiles p = mission::percentiles({5, 1, 4, 2, 3});
  EXPECT_DOUBLE_EQ(p.median, 3.0);
  EXPECT_DOUBLE_EQ(p.max, 5.0);
}

}  // namespace
}  // namespace ridgeline::sim
