#include "planning/kkt_ldlt.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>
#include <vector>

#include "planning/team_scenarios.hpp"
#include "planning/trajectory_optimizer.hpp"

namespace ridgeline::planning {
namespace {

// A symmetric matrix given as triplets (some in the upper triangle, some split into repeated
// entries that must be summed), plus its dense copy for the reference.
struct TripletMatrix {
  int n = 0;
  std::vector<int> rows;
  std::vector<int> cols;
  std::vector<double> values;
  Eigen::MatrixXd dense;

  explicit TripletMatrix(int size) : n(size), dense(Eigen::MatrixXd::Zero(size, size)) {}
  void add(int r, int c, double v, std::mt19937& rng) {
    if (r < c) std::swap(r, c);
    dense(r, c) += v;
    if (r != c) dense(c, r) += v;
    const bool upper = std::bernoulli_distribution(0.5)(rng);
    if (std::bernoulli_distribution(0.2)(rng)) {  // a repeated entry: two halves
      push(upper ? c : r, upper ? r : c, 0.5 * v);
      push(r, c, 0.5 * v);
    } else {
      push(upper ? c : r, upper ? r : c, v);
    }
  }
  void push(int r, int c, double v) {
    rows.push_back(r);
    cols.push_back(c);
    values.push_back(v);
  }
};

// Ipopt's augmented system for n variables and m inequality rows, in Ipopt's order
// [x, s, d]: [H + Σ_x, 0, Jᵀ; 0, Σ_s, −I; J, −I, −δ_d I]. H = B Bᵀ (sparse B) + `shift`·I.
TripletMatrix kkt(int n, int m, double shift, double delta_d, std::mt19937& rng) {
  TripletMatrix a(n + 2 * m);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> sigma(1e-3, 1e3);
  std::uniform_int_distribution<int> col(0, n - 1);
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) {
    b(i, i) = u(rng);
    b(i, col(rng)) += u(rng);
  }
  const Eigen::MatrixXd h = b * b.transpose() + shift * Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j)
      if (h(i, j) != 0.0 || i == j) a.add(i, j, h(i, j) + (i == j ? sigma(rng) * 1e-3 : 0.0), rng);
  for (int r = 0; r < m; ++r) {
    const int s = n + r;
    const int d = n + m + r;
    a.add(s, s, sigma(rng), rng);
    a.add(d, s, -1.0, rng);
    a.add(d, d, -delta_d, rng);
    for (int t = 0; t < 3; ++t) a.add(d, col(rng), u(rng), rng);
  }
  return a;
}

int dense_negative_eigenvalues(const Eigen::MatrixXd& a) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(a);
  return static_cast<int>((eig.eigenvalues().array() < 0.0).count());
}

TEST(SparseLdlt, SolvesIpoptsAugmentedSystemsAndCountsTheirNegativeEigenvalues) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 5 + trial;
    const int m = 2 + (trial * 7) % (n + 3);  // fewer and more rows than variables
    const TripletMatrix a = kkt(n, m, 1e-2, trial % 2 == 0 ? 0.0 : 1e-8, rng);
    SparseLdlt ldlt;
    ldlt.analyze(a.n, a.rows, a.cols);
    ASSERT_EQ(ldlt.factorize(a.values), SparseLdlt::Status::kOk) << "trial " << trial;
    // A positive definite H gives exactly one negative eigenvalue per constraint row.
    EXPECT_EQ(ldlt.negative_pivots(), m) << "trial " << trial;
    EXPECT_EQ(ldlt.negative_pivots(), dense_negative_eigenvalues(a.dense)) << "trial " << trial;
    Eigen::VectorXd b = Eigen::VectorXd::Random(a.n);
    Eigen::VectorXd x = b;
    ldlt.solve(std::span<double>(x.data(), static_cast<std::size_t>(x.size())));
    const double residual = (a.dense * x - b).norm() / (a.dense.norm() * x.norm() + b.norm());
    EXPECT_LT(residual, 1e-12) << "trial " << trial;
  }
}

TEST(SparseLdlt, ReportsTheInertiaOfAnIndefiniteHessian) {
  // H with negative eigenvalues: the count of negative pivots is still the matrix's own count
  // of negative eigenvalues (Sylvester), which is how Ipopt sees that it must regularize.
  std::mt19937 rng(11);
  int more_than_rows = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const int n = 6 + trial % 10;
    const int m = 1 + trial % 4;
    const TripletMatrix a = kkt(n, m, -0.8, 1e-6, rng);
    SparseLdlt ldlt;
    ldlt.analyze(a.n, a.rows, a.cols);
    if (ldlt.factorize(a.values) != SparseLdlt::Status::kOk) continue;  // an exact zero pivot
    EXPECT_EQ(ldlt.negative_pivots(), dense_negative_eigenvalues(a.dense)) << "trial " << trial;
    if (ldlt.negative_pivots() > m) ++more_than_rows;
  }
  EXPECT_GT(more_than_rows, 10) << "the matrices must really be of the wrong inertia";
}

TEST(SparseLdlt, AZeroPivotIsSingularAndRefactoringWithNewValuesRecovers) {
  std::mt19937 rng(5);
  TripletMatrix a = kkt(4, 2, 1.0, 0.0, rng);
  // A variable with no Hessian, no bound term and no constraint: its row is all zero.
  TripletMatrix b(a.n + 1);
  for (std::size_t k = 0; k < a.rows.size(); ++k) b.push(a.rows[k], a.cols[k], a.values[k]);
  b.push(a.n, a.n, 0.0);
  SparseLdlt ldlt;
  ldlt.analyze(b.n, b.rows, b.cols);
  EXPECT_EQ(ldlt.factorize(b.values), SparseLdlt::Status::kSingular);
  b.values.back() = 1e-4;  // what Ipopt's δ_x regularization does
  ASSERT_EQ(ldlt.factorize(b.values), SparseLdlt::Status::kOk);
  EXPECT_EQ(ldlt.negative_pivots(), 2);
}

TEST(SparseLdlt, RejectsAPatternOutOfRange) {
  SparseLdlt ldlt;
  const std::vector<int> rows = {0, 3};
  const std::vector<int> cols = {0, 1};
  EXPECT_THROW(ldlt.analyze(3, rows, cols), std::invalid_argument);
}

// Waypoints per UAV of the planner tests below. The optimizer checks its waypoints as timed
// (time_parametrize_timed); on 30 the timed references of these crossing lines lag the grid's
// times enough to come within d_safe, and no refinement repairs that (the planner would fly the
// initial paths); on 50 they keep the times (TrajectoryOptimizer.ThreeUavsOnDefaultLikeTerrain-
// PassDenseValidation plans the same team on 50).
constexpr int kWaypoints = 50;

// The planner with our factorization and with MUMPS: the same NLP solved to the same point
// (Ipopt's iterates differ only by round-off, so the tolerance is Ipopt's own).
TEST(IpoptKktSolver, PlansTheSameTrajectoriesAsMumps) {
  const world::PeakTerrain terrain = default_like_terrain();
  const TrajectoryProblem problem = straight_line_team(terrain, 3);
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = kWaypoints;
  o.kkt_factorization = KktFactorization::kMumps;
  const TrajectoryResult mumps = optimize_trajectories(problem, o);
  o.kkt_factorization = KktFactorization::kSparseLdlt;
  const long before = IpoptKktSolver::factorizations();
  const TrajectoryResult ours = optimize_trajectories(problem, o);
  ASSERT_TRUE(mumps.ok()) << mumps.message;
  ASSERT_TRUE(ours.ok()) << ours.message;
  EXPECT_GE(IpoptKktSolver::factorizations() - before, ours.ipopt_iterations);
  EXPECT_NEAR(ours.objective, mumps.objective, 1e-5 * std::abs(mumps.objective));
  // The iterates agree to round-off for dozens of iterations, then the line search's
  // decisions may part; the count stays of the same order.
  EXPECT_LE(ours.ipopt_iterations, 2 * mumps.ipopt_iterations + 10);
  ASSERT_EQ(ours.paths.size(), mumps.paths.size());
  for (std::size_t i = 0; i < ours.paths.size(); ++i) {
    ASSERT_EQ(ours.paths[i].waypoints_m.size(), mumps.paths[i].waypoints_m.size());
    for (std::size_t k = 0; k < ours.paths[i].waypoints_m.size(); ++k)
      EXPECT_LT((ours.paths[i].waypoints_m[k] - mumps.paths[i].waypoints_m[k]).norm(), 0.05)
          << "UAV " << i << " waypoint " << k;
  }
}

// Monte Carlo plans on several threads at once: each thread's Ipopt solves keep their own
// factorizations, and the plans equal the ones made alone.
TEST(IpoptKktSolver, ConcurrentSolvesOnSeveralThreadsMatchTheSequentialOnes) {
  const world::PeakTerrain terrain = default_like_terrain();
  std::vector<TrajectoryProblem> problems = {straight_line_team(terrain, 2),
                                             straight_line_team(terrain, 3)};
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = kWaypoints;
  std::vector<double> alone;
  for (const TrajectoryProblem& p : problems) {
    const TrajectoryResult r = optimize_trajectories(p, o);
    ASSERT_TRUE(r.ok()) << to_string(r.status) << ": " << r.message;
    alone.push_back(r.objective);
  }
  std::vector<double> together(problems.size(), 0.0);
  std::vector<std::thread> threads;
  for (std::size_t k = 0; k < problems.size(); ++k)
    threads.emplace_back([&, k] {
      for (int repeat = 0; repeat < 3; ++repeat)
        together[k] = optimize_trajectories(problems[k], o).objective;
    });
  for (std::thread& t : threads) t.join();
  for (std::size_t k = 0; k < problems.size(); ++k) {
    EXPECT_GT(alone[k], 0.0);
    EXPECT_EQ(together[k], alone[k]) << "problem " << k;
  }
}

// Ipopt reads ./ipopt.opt by default; a stray one (here: one iteration, the wrong solver) must
// not change what the planner does.
TEST(IpoptKktSolver, AnOptionsFileInTheWorkingDirectoryIsIgnored) {
  const world::PeakTerrain terrain = default_like_terrain();
  const TrajectoryProblem problem = straight_line_team(terrain, 2);
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 20;
  const TrajectoryResult reference = optimize_trajectories(problem, o);
  ASSERT_TRUE(reference.ok()) << reference.message;
  const auto cwd = std::filesystem::current_path();
  const auto dir = std::filesystem::temp_directory_path() / "ridgeline_ipopt_opt_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "ipopt.opt") << "max_iter 1\nlinear_solver ma57\n";
  std::filesystem::current_path(dir);
  const TrajectoryResult r = optimize_trajectories(problem, o);
  std::filesystem::current_path(cwd);
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.ipopt_iterations, reference.ipopt_iterations);
  EXPECT_DOUBLE_EQ(r.objective, reference.objective);
}

}  // namespace
}  // namespace ridgeline::planning
