// `ridgeline bench qp`'s core: a sequence of QPs solved in order, hot-started, each timed as its
// minimum over the passes, checked for violation and against a tight reference, and reported
// with the processor and its speed. Instances are built here: a drifting tracking QP with box
// bounds and two-sided rows, as the MPC's, whose unconstrained minimum leaves the box.
#include "benchmarks/qp_benchmark.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <vector>

#include "core/random.hpp"

namespace ridgeline::benchmarks {
namespace {

std::vector<qp::QpProblem> drifting_instances(int count, int n, int m) {
  Rng rng(11);
  Eigen::MatrixXd M(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) M(i, j) = rng.normal();
  }
  Eigen::MatrixXd G(m, n);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < n; ++j) G(i, j) = rng.normal();
  }
  std::vector<qp::QpProblem> out;
  for (int k = 0; k < count; ++k) {
    qp::QpProblem q;
    q.H = M.transpose() * M + n * Eigen::MatrixXd::Identity(n, n);
    q.f = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < n; ++i) q.f[i] = -40.0 * std::sin(0.1 * k + i);  // drifts step to step
    q.lb = Eigen::VectorXd::Constant(n, -1.0);
    q.ub = Eigen::VectorXd::Constant(n, 1.0);
    q.G = G;
    q.lg = Eigen::VectorXd::Constant(m, -2.0);
    q.ug = Eigen::VectorXd::Constant(m, 2.0);
    out.push_back(q);
  }
  return out;
}

TEST(QpBenchmark, SolvesEveryInstanceInOrderAndReportsTheGapViolationAndHost) {
  const std::vector<qp::QpProblem> instances = drifting_instances(40, 8, 12);
  QpBenchmarkOptions options;
  options.reference = QpReference::kInteriorPoint;
  options.repeats = 2;
  const QpBenchmarkReport r = run_qp_benchmark(instances, options);
  EXPECT_EQ(r.count, 40);
  EXPECT_EQ(r.repeats, 2);
  EXPECT_TRUE(r.failures.empty());
  EXPECT_EQ(r.nondeterministic, 0);
  EXPECT_EQ(r.reference_failures, 0);
  // Constraints bind (the unconstrained minimum lies outside the box and the rows in every
  // instance), so the active set iterates, also hot-started; the active set answers, not its
  // interior-point fallback, and agrees with the tight reference.
  EXPECT_GE(r.iterations.median, 1.0);
  EXPECT_EQ(r.fallbacks, 0);
  EXPECT_LT(r.max_violation, 1e-8);
  EXPECT_LT(r.max_rel_objective_gap, 1e-6);
  EXPECT_GT(r.solve_us.median, 0.0);
  EXPECT_LE(r.solve_us.median, r.solve_us.p99);
  EXPECT_GT(r.floor_llt_us_median, 0.0);
  // The host: its speed before and after the timed passes, and the processor.
  EXPECT_GT(r.host_speed.before, 0.0);
  EXPECT_GT(r.host_speed.after, 0.0);
  EXPECT_EQ(r.host_speed.processor, this_processor());
  const nlohmann::json j = r.to_json();
  EXPECT_EQ(j["count"], 40);
  EXPECT_EQ(j["failures"]["count"], 0);
  EXPECT_EQ(j["host_speed"]["processor"].get<std::string>(), r.host_speed.processor);
  EXPECT_DOUBLE_EQ(j["median_over_floor"].get<double>(), r.solve_us.median / r.floor_llt_us_median);
}

// An instance no point satisfies is a failure, named by its index; the others still count.
TEST(QpBenchmark, AnInfeasibleInstanceIsAFailureNamedByItsIndex) {
  std::vector<qp::QpProblem> instances = drifting_instances(6, 5, 4);
  instances[3].lg[0] = 1e3;  // row 0 ≥ 1000 within the unit box: impossible
  instances[3].ug[0] = 2e3;
  QpBenchmarkOptions options;
  options.reference = QpReference::kNone;
  options.repeats = 1;
  const QpBenchmarkReport r = run_qp_benchmark(instances, options);
  ASSERT_EQ(r.failures.size(), 1u);
  EXPECT_EQ(r.failures[0], 3);
  EXPECT_EQ(r.to_json()["failures"]["indices"][0], 3);
  EXPECT_EQ(r.max_rel_objective_gap, 0.0);  // no reference asked
}

}  // namespace
}  // namespace ridgeline::benchmarks
