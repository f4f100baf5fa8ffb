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
    // A flight times one step in 32 in CPU time (sim/method.cpp), each window also holding
    // part of the CPU clock's own system calls: those few steps' median sits above the
    // wall-clock median of all the steps (3 µs on an idle development host, 7 µs on a loaded CI
    // host), so it is bounded by the wall-clock tail (a unit or clock mix-up would still be off
    // by orders of magnitude).
    EXPECT_LE(run.mpc_step_cpu_us.median, run.mpc_step_us.p99 * 1.05 + 5.0);
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
  // The host's speed is read before and after the flights (dependent_adds_per_ns's own bounds
  // are tested below).
  EXPECT_GT(r.host_speed.before, 0.0);
  EXPECT_GT(r.host_speed.after, 0.0);
  EXPECT_EQ(j["host_speed"]["dependent_adds_per_ns_before"].get<double>(), r.host_speed.before);
  EXPECT_EQ(j["host_speed"]["dependent_adds_per_ns_after"].get<double>(), r.host_speed.after);
  // And the processor it ran on.
  EXPECT_EQ(r.host_speed.processor, this_processor());
  EXPECT_EQ(j["host_speed"]["processor"].get<std::string>(), r.host_speed.processor);
  // The interruption probe ran (its own logic is tested in host_interruptions_test.cpp).
  EXPECT_GE(r.host_interruptions.probed_ms, kInterruptionProbeMs);
  EXPECT_EQ(j["host_interruptions"]["count"].get<int>(), r.host_interruptions.count);
}

// The host-speed reading times a chain of dependent additions: a compiler that folded or
// vectorized it would report hundreds of additions a nanosecond or more, and no core of this
// century does fewer than 0.01 (10 MHz) or more than 50 in a dependent chain.
TEST(HostSpeed, DependentAdditionsTakeAboutOneCycleEach) {
  for (const int samples : {1, 3}) {
    const double rate = dependent_adds_per_ns(samples);
    EXPECT_GT(rate, 0.01) << samples;
    EXPECT_LT(rate, 50.0) << samples;
  }
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
