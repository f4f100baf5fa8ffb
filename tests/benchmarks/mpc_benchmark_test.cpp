// The MPC step benchmark (`ridgeline bench mpc`): its closed loop solves every step, and its
// derived figures follow from the ones it measured.
#include "benchmarks/mpc_benchmark.hpp"

#include <gtest/gtest.h>

namespace ridgeline::benchmarks {
namespace {

TEST(MpcBenchmark, EveryStepSolvesAndTheDerivedFiguresFollowFromTheMeasuredOnes) {
  MpcBenchmarkOptions options;
  options.steps = 120;
  options.ipopt_every = 40;
  const MpcBenchmarkReport r = run_mpc_benchmark(options);
  EXPECT_EQ(r.steps, 120);
  EXPECT_EQ(r.not_solved, 0);
  EXPECT_EQ(r.qp_fallbacks, 0);
  EXPECT_EQ(r.ipopt_compared, 3);
  EXPECT_LT(r.max_rel_objective_gap, 1e-6);
  // Every kind of soft row is active (threats, neighbours, terrain), and redundant rows are
  // left out of the QP.
  EXPECT_GT(r.soft_rows_mean, 50.0);
  EXPECT_GT(r.soft_rows_in_qp_mean, 0.0);
  EXPECT_LT(r.soft_rows_in_qp_mean, r.soft_rows_mean);
  EXPECT_GT(r.step_us.median, 0.0);
  EXPECT_LE(r.step_us.median, r.step_us.p99);
  // The QP and each part are inside the step (medians of parts of the same steps).
  EXPECT_LE(r.parts.qp_us, r.step_us.p99);
  EXPECT_GT(r.parts.condensing_us, 0.0);
  EXPECT_DOUBLE_EQ(r.step_over_qp, r.step_cpu_us.median / r.qp_us.median);
  // The interruption probe ran before the steps, and the share follows from it.
  EXPECT_GE(r.host_interruptions.probed_ms, kInterruptionProbeMs);
  EXPECT_DOUBLE_EQ(r.interrupted_step_share_expected,
                   r.host_interruptions.per_ms * r.step_us.median / 1000.0);
  const nlohmann::json j = r.to_json();
  EXPECT_EQ(j["host_interruptions"]["count"].get<int>(), r.host_interruptions.count);
  EXPECT_DOUBLE_EQ(j["interrupted_step_share_expected"].get<double>(),
                   r.interrupted_step_share_expected);
  EXPECT_DOUBLE_EQ(j["mpc_step_us"]["median"].get<double>(), r.step_us.median);
}

}  // namespace
}  // namespace ridgeline::benchmarks
