// Hand-checkable problems for ridgeline::qp::QpSolver: the optimum of each is derived in the
// comment above it. Tolerances: the solver stops at a relative KKT residual of 1e-9 on data of
// order 1, so z and the multipliers are accurate to ~1e-8; 1e-7 leaves a margin.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>

#include <Eigen/Dense>

#include "qp/qp_solver.hpp"

// Counts heap allocations so that the no-allocation promise of solve() can be tested: this
// definition interposes glibc's malloc for this test program only. AddressSanitizer interposes
// malloc itself, so under it the count is off and that test is skipped.
namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
}  // namespace
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kCountingMalloc = false;
#else
constexpr bool kCountingMalloc = true;
extern "C" void* __libc_malloc(std::size_t size);
extern "C" void* malloc(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  return __libc_malloc(size);
}
#endif

namespace ridgeline::qp {
namespace {

constexpr double kTol = 1e-7;

QpProblem box_problem(Eigen::MatrixXd H, Eigen::VectorXd f) {
  QpProblem q;
  const Eigen::Index n = H.rows();
  q.H = std::move(H);
  q.f = std::move(f);
  q.G.resize(0, n);
  q.A.resize(0, n);
  return q;
}

// ½(2z₁² + 4z₂²) − 2z₁ − 8z₂: z = (1, 2), objective −9.
TEST(QpSolverTest, UnconstrainedQuadraticIsSolvedByOneNewtonStep) {
  QpSolver solver;
  const QpResult& r =
      solver.solve(box_problem(Eigen::Vector2d(2, 4).asDiagonal(), Eigen::Vector2d(-2, -8)));
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_NEAR(r.z[0], 1.0, kTol);
  EXPECT_NEAR(r.z[1], 2.0, kTol);
  EXPECT_NEAR(r.objective, -9.0, kTol);
  EXPECT_LE(r.iterations, 2);
}

// ½‖z‖² − (3, −3, 0.5)ᵀz on [−1, 1]³: z = (1, −1, 0.5); from z + f + w = 0 the bound
// multipliers are w = (2, −2, 0) (+ upper active, − lower active).
TEST(QpSolverTest, BoxConstrainedProblemReportsSignedBoundMultipliers) {
  QpProblem q = box_problem(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-3, 3, -0.5));
  q.lb = Eigen::Vector3d::Constant(-1.0);
  q.ub = Eigen::Vector3d::Constant(1.0);
  QpSolver solver;
  const QpResult& r = solver.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_NEAR((r.z - Eigen::Vector3d(1, -1, 0.5)).cwiseAbs().maxCoeff(), 0.0, kTol);
  EXPECT_NEAR((r.dual_bounds - Eigen::Vector3d(2, -2, 0)).cwiseAbs().maxCoeff(), 0.0, kTol);
  EXPECT_LE(r.primal_residual, kTol);
  EXPECT_LE(r.dual_residual, kTol);
  EXPECT_GT(r.solve_time_us, 0.0);
}

// ½‖z‖² s.t. z₁ + z₂ = 2: z = (1, 1), and z + Aᵀy = 0 gives y = −1.
TEST(QpSolverTest, EqualityConstrainedProblem) {
  QpProblem q = box_problem(Eigen::Matrix2d::Identity(), Eigen::Vector2d::Zero());
  q.A = Eigen::RowVector2d(1, 1);
  q.b = Eigen::VectorXd::Constant(1, 2.0);
  QpSolver solver;
  const QpResult& r = solver.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_NEAR(r.z[0], 1.0, kTol);
  EXPECT_NEAR(r.z[1], 1.0, kTol);
  EXPECT_NEAR(r.dual_eq[0], -1.0, kTol);
  EXPECT_NEAR(r.objective, 1.0, kTol);
}

// ½‖z − (2, 2)‖² s.t. z₁ + z₂ ≤ 2 (and an inactive lower side −10): projection onto the
// half-plane, z = (1, 1), row multiplier 1 (upper side active), objective ½·2 − 4 = −3.
TEST(QpSolverTest, KnownActiveSetOfATwoSidedRow) {
  QpProblem q = box_problem(Eigen::Matrix2d::Identity(), Eigen::Vector2d(-2, -2));
  q.G = Eigen::RowVector2d(1, 1);
  q.lg = Eigen::VectorXd::Constant(1, -10.0);
  q.ug = Eigen::VectorXd::Constant(1, 2.0);
  QpSolver solver;
  const QpResult& r = solver.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_NEAR(r.z[0], 1.0, kTol);
  EXPECT_NEAR(r.z[1], 1.0, kTol);
  EXPECT_NEAR(r.dual_rows[0], 1.0, kTol);
  EXPECT_NEAR(r.objective, -3.0, kTol);
}

// A row with lg == ug and a variable with lb == ub are equalities: ½‖z‖² with z₁ − z₂ = 1 and
// z₃ = 2 gives z = (0.5, −0.5, 2); multipliers −0.5 (row) and −2 (fixed variable).
TEST(QpSolverTest, EqualSidesAreTreatedAsEqualities) {
  QpProblem q = box_problem(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  q.G = Eigen::RowVector3d(1, -1, 0);
  q.lg = q.ug = Eigen::VectorXd::Constant(1, 1.0);
  q.lb = Eigen::Vector3d(-kInfinity, -kInfinity, 2.0);
  q.ub = Eigen::Vector3d(kInfinity, kInfinity, 2.0);
  QpSolver solver;
  const QpResult& r = solver.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_NEAR((r.z - Eigen::Vector3d(0.5, -0.5, 2.0)).cwiseAbs().maxCoeff(), 0.0, kTol);
  EXPECT_NEAR(r.dual_rows[0], -0.5, kTol);
  EXPECT_NEAR(r.dual_bounds[2], -2.0, kTol);
}

// 0 ≤ z ≤ 1 and z₁ + z₂ ≥ 3 cannot hold together (Farkas: w = (1, 1, −1)).
TEST(QpSolverTest, DetectsPrimalInfeasibility) {
  QpProblem q = box_problem(Eigen::Matrix2d::Identity(), Eigen::Vector2d(1, 1));
  q.lb = Eigen::Vector2d::Zero();
  q.ub = Eigen::Vector2d::Ones();
  q.G = Eigen::RowVector2d(1, 1);
  q.lg = Eigen::VectorXd::Constant(1, 3.0);
  q.ug = Eigen::VectorXd::Constant(1, kInfinity);
  QpSolver solver;
  EXPECT_EQ(solver.solve(q).status, QpStatus::kPrimalInfeasible);
}

// H = diag(0, 1), f = (−1, 0), z₁ ≥ 0: the objective falls without bound along d = (1, 0).
TEST(QpSolverTest, DetectsDualInfeasibility) {
  QpProblem q = box_problem(Eigen::Vector2d(0, 1).asDiagonal(), Eigen::Vector2d(-1, 0));
  q.lb = Eigen::Vector2d(0, -1);
  q.ub = Eigen::Vector2d(kInfinity, 1);
  QpSolver solver;
  EXPECT_EQ(solver.solve(q).status, QpStatus::kDualInfeasible);
}

TEST(QpSolverTest, RejectsInvalidInput) {
  const QpProblem good = box_problem(Eigen::Matrix2d::Identity(), Eigen::Vector2d(1, 1));
  QpSolver solver;
  ASSERT_EQ(solver.solve(good).status, QpStatus::kSolved);

  QpProblem nan_h = good;
  nan_h.H(0, 0) = std::nan("");
  EXPECT_EQ(solver.solve(nan_h).status, QpStatus::kInvalidInput);
  QpProblem inf_f = good;
  inf_f.f[1] = kInfinity;
  EXPECT_EQ(solver.solve(inf_f).status, QpStatus::kInvalidInput);
  QpProblem wrong_size = good;
  wrong_size.f.resize(3);
  EXPECT_EQ(solver.solve(wrong_size).status, QpStatus::kInvalidInput);
  QpProblem crossed = good;
  crossed.lb = Eigen::Vector2d(1, 0);
  crossed.ub = Eigen::Vector2d(0, 1);
  EXPECT_EQ(solver.solve(crossed).status, QpStatus::kInvalidInput);
  QpProblem crossed_rows = good;
  crossed_rows.G = Eigen::RowVector2d(1, 0);
  crossed_rows.lg = Eigen::VectorXd::Constant(1, 2.0);
  crossed_rows.ug = Eigen::VectorXd::Constant(1, 1.0);
  EXPECT_EQ(solver.solve(crossed_rows).status, QpStatus::kInvalidInput);
  QpProblem nan_bound = good;
  nan_bound.ug = nan_bound.lg = Eigen::VectorXd::Constant(1, std::nan(""));
  nan_bound.G = Eigen::RowVector2d(1, 0);
  EXPECT_EQ(solver.solve(nan_bound).status, QpStatus::kInvalidInput);
  QpProblem asymmetric = good;
  asymmetric.H(0, 1) = 0.5;
  EXPECT_EQ(solver.solve(asymmetric).status, QpStatus::kInvalidInput);
  EXPECT_EQ(to_string(QpStatus::kInvalidInput), "invalid input");
}

// The input checks read H in 4×4 tiles and the vectors four at a time with a scalar tail:
// every position of every size, inside a tile, on the diagonal tiles and in the tail, must be
// seen. An asymmetry just over the tolerance (1e-10 relative) is rejected wherever it is, one
// just under it is accepted; a NaN or an infinity anywhere is rejected, while the largest
// finite values, −0 and denormals are accepted.
TEST(QpSolverTest, InputChecksSeeEveryEntry) {
  QpSolver solver;
  for (int n = 1; n <= 13; ++n) {
    QpProblem q;
    q.H = Eigen::MatrixXd::Identity(n, n) * 4.0;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) q.H(i, j) = q.H(j, i) = 0.1 / (1.0 + i + j);
    }
    q.f = Eigen::VectorXd::LinSpaced(n, -1.0, 1.0);
    q.G.resize(0, n);
    q.A.resize(0, n);
    ASSERT_EQ(solver.solve(q).status, QpStatus::kSolved) << n;
    const double tol = 1e-10 * 4.0;  // relative to max |H_ij| = 4
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        if (i == j) continue;
        QpProblem bad = q;
        bad.H(i, j) += 1.5 * tol;
        EXPECT_EQ(solver.solve(bad).status, QpStatus::kInvalidInput) << n << " " << i << " " << j;
        bad.H(i, j) = q.H(i, j) - 0.5 * tol;
        EXPECT_NE(solver.solve(bad).status, QpStatus::kInvalidInput) << n << " " << i << " " << j;
      }
    }
    for (int i = 0; i < n; ++i) {  // a NaN or an infinity anywhere in H, the diagonal too
      for (int j = 0; j < n; ++j) {
        for (const double v : {std::nan(""), kInfinity}) {
          QpProblem bad = q;
          bad.H(i, j) = v;
          EXPECT_EQ(solver.solve(bad).status, QpStatus::kInvalidInput) << n << " H " << i << j;
        }
      }
    }
  }
  {  // entries so large that H(i, j) − H(j, i) overflows: rejected, not accepted as symmetric
    QpProblem q;
    const double big = std::numeric_limits<double>::max();
    q.H = Eigen::Matrix4d::Identity();
    q.H(2, 1) = big;
    q.H(1, 2) = -big;
    q.f = Eigen::Vector4d::Zero();
    q.G.resize(0, 4);
    q.A.resize(0, 4);
    EXPECT_EQ(solver.solve(q).status, QpStatus::kInvalidInput);
  }
  for (int n = 1; n <= 40; ++n) {
    QpProblem q;
    q.H = Eigen::MatrixXd::Identity(n, n);
    q.f = Eigen::VectorXd::Zero(n);
    q.G = Eigen::MatrixXd::Identity(n, n);
    q.lg = Eigen::VectorXd::Constant(n, -1.0);
    q.ug = Eigen::VectorXd::Constant(n, 1.0);
    q.A.resize(0, n);
    q.f[0] = std::numeric_limits<double>::max();
    q.f[n - 1] = -0.0;
    if (n > 2) q.f[1] = std::numeric_limits<double>::denorm_min();
    EXPECT_NE(solver.solve(q).status, QpStatus::kInvalidInput) << n;
    for (int i = 0; i < n; ++i) {
      for (const double v : {std::nan(""), kInfinity, -kInfinity}) {
        QpProblem bad = q;
        bad.f[i] = v;
        EXPECT_EQ(solver.solve(bad).status, QpStatus::kInvalidInput) << n << " f " << i;
        bad = q;
        bad.G(i, (i * 7) % n) = v;
        EXPECT_EQ(solver.solve(bad).status, QpStatus::kInvalidInput) << n << " G " << i;
      }
    }
  }
}

// Rows of G with no finite side (free rows) constrain nothing, yet a NaN or an infinity in one
// is still bad input: free rows in the middle and at the end, every entry of each, for
// sizes around the checks' groups of four and sixteen entries. The active set reads G only
// through its product over the rows before the trailing free ones; those it checks after the
// solve (the interior point checks all of G before).
TEST(QpSolverTest, InputChecksSeeTheFreeRowsOfG) {
  QpSolver solver({.method = QpMethod::kActiveSet});
  for (const int n : {1, 3, 4, 5, 17, 33}) {
    const int m = n + 4;
    QpProblem q;
    q.H = Eigen::MatrixXd::Identity(n, n);
    q.f = Eigen::VectorXd::LinSpaced(n, -2.0, 2.0);
    q.G = Eigen::MatrixXd::Zero(m, n);
    q.lg = Eigen::VectorXd::Constant(m, -1.0);
    q.ug = Eigen::VectorXd::Constant(m, 1.0);
    for (int i = 0; i < n; ++i) q.G(i < n / 2 ? i : i + 1, i) = 1.0;
    const int free_rows[] = {n / 2, m - 3, m - 2, m - 1};
    for (const int r : free_rows) {
      q.G.row(r).setConstant(0.5);
      q.lg[r] = -kInfinity;
      q.ug[r] = kInfinity;
    }
    q.A.resize(0, n);
    ASSERT_EQ(solver.solve(q).status, QpStatus::kSolved) << n;
    for (const int r : free_rows) {
      for (int c = 0; c < n; ++c) {
        for (const double v : {std::nan(""), kInfinity, -kInfinity}) {
          QpProblem bad = q;
          bad.G(r, c) = v;
          EXPECT_EQ(solver.solve(bad).status, QpStatus::kInvalidInput) << n << " " << r << " " << c;
        }
      }
    }
  }
}

// The tolerance of the symmetry test is relative to the largest |H_ij|, found eight entries at
// a time with a scalar tail: a largest entry (of either sign) at any diagonal position of any size
// must set it. And the sides (lb ≤ ub, lg ≤ ug), read four pairs at a time: a NaN, a crossed
// pair, a lower side of +∞ or an upper one of −∞ at any position is rejected, an absent side
// (±∞ the right way) and an equality are accepted, with one of lb and ub absent too.
TEST(QpSolverTest, InputChecksFindTheScaleAndEverySide) {
  QpSolver solver;
  for (int n = 2; n <= 13; ++n) {
    for (int i = 0; i < n; ++i) {
      for (const double largest : {1e4, -1e4}) {
        QpProblem q;
        q.H = Eigen::MatrixXd::Identity(n, n);
        q.H(i, i) = largest;
        q.f = Eigen::VectorXd::Zero(n);
        q.G.resize(0, n);
        q.A.resize(0, n);
        const double tol = 1e-10 * 1e4;
        const int a = i == 0 ? 1 : 0;  // an off-diagonal pair away from the largest entry
        q.H(a, i) += 0.5 * tol;
        EXPECT_NE(solver.solve(q).status, QpStatus::kInvalidInput) << n << " " << i;
        q.H(a, i) += 1.0 * tol;
        EXPECT_EQ(solver.solve(q).status, QpStatus::kInvalidInput) << n << " " << i;
      }
    }
  }
  const double nan = std::nan("");
  for (int n = 1; n <= 13; ++n) {
    QpProblem q;
    q.H = Eigen::MatrixXd::Identity(n, n);
    q.f = Eigen::VectorXd::LinSpaced(n, -1.0, 1.0);
    q.lb = Eigen::VectorXd::Constant(n, -2.0);
    q.ub = Eigen::VectorXd::Constant(n, 2.0);
    q.G = Eigen::MatrixXd::Identity(n, n);
    q.lg = Eigen::VectorXd::Constant(n, -1.0);
    q.ug = Eigen::VectorXd::Constant(n, 1.0);
    q.A.resize(0, n);
    ASSERT_EQ(solver.solve(q).status, QpStatus::kSolved) << n;
    for (int i = 0; i < n; ++i) {
      // (lower, upper) pairs at position i, and whether they are usable.
      const std::pair<std::pair<double, double>, bool> cases[] = {
          {{nan, 1.0}, false},        {{-1.0, nan}, false},         {{1.5, 0.5}, false},
          {{1e20, kInfinity}, false}, {{-kInfinity, -1e20}, false}, {{-kInfinity, kInfinity}, true},
          {{0.25, 0.25}, true},       {{-1e19, 1e19}, true},        {{0.0, -0.0}, true},
          {{-0.0, 0.0}, true}};
      for (const auto& [sides, usable] : cases) {
        QpProblem bad = q;
        bad.lb[i] = sides.first;
        bad.ub[i] = sides.second;
        EXPECT_EQ(solver.solve(bad).status != QpStatus::kInvalidInput, usable)
            << n << " lb/ub " << i << " " << sides.first << " " << sides.second;
        bad = q;
        bad.lg[i] = sides.first;
        bad.ug[i] = sides.second;
        EXPECT_EQ(solver.solve(bad).status != QpStatus::kInvalidInput, usable)
            << n << " lg/ug " << i << " " << sides.first << " " << sides.second;
      }
      QpProblem upper_only = q;  // lb absent (−∞): only ub is read
      upper_only.lb.resize(0);
      EXPECT_NE(solver.solve(upper_only).status, QpStatus::kInvalidInput) << n;
      upper_only.ub[i] = nan;
      EXPECT_EQ(solver.solve(upper_only).status, QpStatus::kInvalidInput) << n << " ub " << i;
      upper_only.ub[i] = -1e20;
      EXPECT_EQ(solver.solve(upper_only).status, QpStatus::kInvalidInput) << n << " ub " << i;
      QpProblem lower_only = q;  // ub absent (+∞)
      lower_only.ub.resize(0);
      lower_only.lb[i] = 1e20;
      EXPECT_EQ(solver.solve(lower_only).status, QpStatus::kInvalidInput) << n << " lb " << i;
      lower_only.lb[i] = nan;
      EXPECT_EQ(solver.solve(lower_only).status, QpStatus::kInvalidInput) << n << " lb " << i;
    }
  }
}

// A sequence of nearby QPs like the MPC's: a tracking problem whose target moves a little each
// step, with box and row limits that become active. Warm starts must give the same solutions
// and need fewer iterations in total than cold starts.
class QpSequence {
 public:
  QpSequence() {
    const int n = 12;
    Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, n);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j <= i; ++j) L(i, j) = 1.0 / (1.0 + i - j);
    }
    q_.H = L.transpose() * L + 0.1 * Eigen::MatrixXd::Identity(n, n);
    q_.lb = Eigen::VectorXd::Constant(n, -0.5);
    q_.ub = Eigen::VectorXd::Constant(n, 0.5);
    q_.G = L;
    q_.lg = Eigen::VectorXd::Constant(n, -1.0);
    q_.ug = Eigen::VectorXd::Constant(n, 1.0);
    q_.A.resize(0, n);
  }
  const QpProblem& at(int step) {
    const int n = static_cast<int>(q_.H.rows());
    const Eigen::VectorXd target = Eigen::VectorXd::NullaryExpr(
        n, [&](Eigen::Index i) { return 2.0 * std::sin(0.05 * step + 0.3 * i); });
    q_.f = -(q_.G.transpose() * target);
    return q_;
  }

 private:
  QpProblem q_;
};

TEST(QpSolverTest, WarmStartReproducesColdSolutionsWithFewerIterations) {
  QpSequence sequence;
  QpSolver warm({.warm_start = true});
  QpSolver cold({.warm_start = false});
  int warm_iterations = 0, cold_iterations = 0;
  for (int step = 0; step < 50; ++step) {
    const QpProblem& q = sequence.at(step);
    const QpResult& rw = warm.solve(q);
    ASSERT_EQ(rw.status, QpStatus::kSolved);
    const Eigen::VectorXd z_warm = rw.z;
    const QpResult& rc = cold.solve(q);
    ASSERT_EQ(rc.status, QpStatus::kSolved);
    EXPECT_LE((z_warm - rc.z).cwiseAbs().maxCoeff(), 1e-6);  // both within ~1e-8 of z*
    if (step > 0) {
      warm_iterations += rw.iterations;
      cold_iterations += rc.iterations;
    }
  }
  EXPECT_LT(warm_iterations, cold_iterations);
  RecordProperty("warm_iterations", warm_iterations);
  RecordProperty("cold_iterations", cold_iterations);
}

TEST(QpSolverTest, ResetForgetsThePreviousSolution) {
  QpSequence sequence;
  QpSolver solver;
  ASSERT_EQ(solver.solve(sequence.at(0)).status, QpStatus::kSolved);
  solver.reset();
  QpSolver fresh;
  const int fresh_iterations = fresh.solve(sequence.at(1)).iterations;
  EXPECT_EQ(solver.solve(sequence.at(1)).iterations, fresh_iterations);
}

TEST(QpSolverTest, SolveDoesNotAllocateAfterTheFirstSolveAtAGivenSize) {
  if (!kCountingMalloc) GTEST_SKIP() << "malloc is interposed by the sanitizer";
  QpSequence sequence;
  QpSolver solver;
  const QpProblem& first = sequence.at(0);
  g_allocations = 0;
  g_counting = true;
  const QpStatus first_status = solver.solve(first).status;
  g_counting = false;
  ASSERT_EQ(first_status, QpStatus::kSolved);
  ASSERT_GT(g_allocations.load(), 0);  // the counter works: the first solve sizes the workspace
  const QpProblem& next = sequence.at(1);  // data prepared before counting
  g_allocations = 0;
  g_counting = true;
  const QpStatus status = solver.solve(next).status;
  g_counting = false;
  EXPECT_EQ(status, QpStatus::kSolved);
  EXPECT_EQ(g_allocations.load(), 0);
}

}  // namespace
}  // namespace ridgeline::qp
