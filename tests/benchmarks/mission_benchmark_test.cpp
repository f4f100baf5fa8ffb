// The closed-loop speed benchmark: its flights are the mission's own (deterministic, safe),
// and its CPU and wall figures are consistent with each other and with the flights.
#include "benchmarks/mission_benchmark.hpp"

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "support/small_mission.hpp"

namespace ridgeline::benchmarks {
namespace {

TEST(MissionBenchmark, RepeatedFlightsAreIdenticalAndTheFactorsFollowFromTheirTimes) {
  const sim::test::Fixture f = sim::test::small_mission(true);
  const MissionBenchmarkReport r = run_mission_benchmark(f.scenario, f.terrain, f.plan, {3});
  ASSERT_EQ(r.runs.size(), 3u);
  EXPECT_TRUE(r.deterministic);
  EXPECT_EQ(r.uavs, 2);
  for (const MissionBenchmarkRun& run : r.runs) {
    EXPECT_TRUE(run.safe);
    EXPECT_TRUE(run.mission_complete);
    EXPECT_GT(run.cpu_time_s, 0.0);
    // One thread's CPU time cannot exceed the wall time it ran in; 10 ms covers the two
    // clocks' different granularities.
    EXPECT_LE(run.cpu_time_s, run.wall_time_s + 0.01);
    EXPECT_GT(run.mpc_step_cpu_us.median, 0.0);
    EXPECT_LE(run.mpc_step_cpu_us.median, run.mpc_step_us.median * 1.05 + 5.0);
  }
  // The factors are medians of sim time / time: bounded by the extreme flights.
  double lo = 1e300, hi = 0.0;
  for (const MissionBenchmarkRun& run : r.runs) {
    lo = std::min(lo, run.sim_time_s / run.cpu_time_s);
    hi = std::max(hi, run.sim_time_s / run.cpu_time_s);
  }
  EXPECT_GE(r.real_time_factor_cpu, lo);
  EXPECT_LE(r.real_time_factor_cpu, hi);
  EXPECT_GE(r.real_time_factor_cpu, r.real_time_factor_wall * 0.95);
  const nlohmann::json j = r.to_json();
  EXPECT_EQ(j["flights"], 3);
  EXPECT_TRUE(j["all_safe"].get<bool>());
}

TEST(MissionBenchmark, ZeroRepeatsIsAnErrorNamingTheField) {
  const sim::test::Fixture f = sim::test::small_mission(false);
  try {
    run_mission_benchmark(f.scenario, f.terrain, f.plan, {0});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("repeats"), std::string::npos);
  }
}

}  // namespace
}  // namespace ridgeline::benchmarks
