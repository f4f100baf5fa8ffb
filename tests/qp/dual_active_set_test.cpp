// The active-set path of ridgeline::qp::QpSolver (QpMethod::kActiveSet, dual_active_set.hpp)
// on hand-made cases: hot starts along an MPC-like sequence agree with the interior point and
// allocate nothing, conflicting sides are reported infeasible (never solved) by a checked
// certificate, and the fallbacks (PSD H, iteration cap) answer correctly and say so. The
// cross-checks against Ipopt on random, degenerate and ill-conditioned instances are in
// qp_solver_ipopt_test.cpp.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "qp/dual_active_set.hpp"
#include "qp/qp_solver.hpp"

// Counts heap allocations (as in qp_solver_test.cpp): this definition interposes glibc's malloc
// for this test program only; under AddressSanitizer the count is off and the test is skipped.
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

double inf_norm(const Eigen::VectorXd& v) { return v.size() ? v.cwiseAbs().maxCoeff() : 0.0; }

// A condensed tracking problem like the MPC's (cumulative moves L, output rows Φ): 30
// variables with move bounds, 190 two-sided rows; the target moves a little every step, so
// consecutive optimal working sets differ in a few sides.
class TrackingSequence {
 public:
  TrackingSequence() {
    constexpr int kMoves = 10, kInputs = 3, kHorizon = 40;
    const int n = kMoves * kInputs;
    phi_ = Eigen::MatrixXd::Zero(kHorizon * kInputs, n);
    for (int j = 0; j < kHorizon; ++j) {
      for (int i = 0; i < std::min(j + 1, kMoves); ++i) {
        phi_.block(kInputs * j, kInputs * i, kInputs, kInputs) =
            0.1 * (j - i + 1) * Eigen::Matrix3d::Identity();
      }
    }
    Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, n);
    for (int i = 0; i < kMoves; ++i) {
      for (int k = 0; k <= i; ++k) L.block(kInputs * i, kInputs * k, kInputs, kInputs).setIdentity();
    }
    q_.H = 2.0 * (phi_.transpose() * phi_ + 0.1 * Eigen::MatrixXd::Identity(n, n));
    q_.lb = Eigen::VectorXd::Constant(n, -1.0);
    q_.ub = Eigen::VectorXd::Constant(n, 1.0);
    q_.G.resize(n + phi_.rows() + 40, n);
    q_.G << L, phi_, phi_.topRows(40);
    q_.lg.resize(q_.G.rows());
    q_.ug.resize(q_.G.rows());
    q_.A.resize(0, n);
  }
  const QpProblem& at(int step) {
    const int n = static_cast<int>(q_.H.rows());
    const double t = 0.02 * step;
    Eigen::VectorXd ref(phi_.rows());
    for (Eigen::Index i = 0; i < ref.size(); ++i) ref[i] = 8.0 * std::sin(0.5 * t + 0.05 * i);
    q_.f = -2.0 * phi_.transpose() * ref;
    q_.lg.head(n).setConstant(-3.0);
    q_.ug.head(n).setConstant(3.0);
    q_.lg.segment(n, phi_.rows()).setConstant(-4.0 - std::sin(t));
    q_.ug.segment(n, phi_.rows()).setConstant(4.0 + std::cos(t));
    q_.lg.tail(40).setConstant(-kInfinity);
    q_.ug.tail(40).setConstant(3.0);
    return q_;
  }

 private:
  Eigen::MatrixXd phi_;
  QpProblem q_;
};

// Hot-started active-set solves against cold interior-point solves (polished, so exact up to
// round-off): objectives to 1e-9 relative, z to 1e-7 (H's condition number here is ~1e4, so
// two exact solutions differ by ~1e-12). The active set must not fall back on this sequence,
// and its hot starts must need far fewer updates than the first, cold solve.
TEST(DualActiveSetTest, HotStartsAlongAnMpcSequenceAgreeWithTheInteriorPoint) {
  TrackingSequence sequence;
  QpSolver fast({.method = QpMethod::kActiveSet});
  QpSolver reference({.warm_start = false});
  int first_iterations = 0, later_iterations = 0, active_sides = 0;
  constexpr int kSteps = 200;
  for (int step = 0; step < kSteps; ++step) {
    const QpProblem& q = sequence.at(step);
    const QpResult& r = fast.solve(q);
    ASSERT_EQ(r.status, QpStatus::kSolved) << "step " << step;
    EXPECT_EQ(r.method, QpMethod::kActiveSet);
    EXPECT_FALSE(r.fell_back);
    const Eigen::VectorXd z = r.z;
    const double objective = r.objective;
    active_sides += static_cast<int>((r.dual_rows.array() != 0.0).count() +
                                     (r.dual_bounds.array() != 0.0).count());
    (step == 0 ? first_iterations : later_iterations) += r.iterations;
    const QpResult& ref = reference.solve(q);
    ASSERT_EQ(ref.status, QpStatus::kSolved);
    EXPECT_NEAR(objective, ref.objective, 1e-9 * std::max(1.0, std::abs(ref.objective)));
    EXPECT_LE(inf_norm(z - ref.z), 1e-7) << "step " << step;
  }
  EXPECT_GT(active_sides, kSteps);  // the sequence does exercise constraints
  EXPECT_GT(first_iterations, 0);
  EXPECT_LT(later_iterations, (kSteps - 1) * 2);  // hot starts: under 2 updates per solve
  RecordProperty("first_iterations", first_iterations);
  RecordProperty("later_iterations", later_iterations);
}

// The factor of H stops each column at its envelope (where its nonzeros end). Hessians with
// structure — uncoupled blocks of different sizes, blocks joined by one entry (fill-in across
// them), an arrow (the last variable coupled to all), a band, isolated variables — must give
// the interior point's optimum, cold and hot started, with rows that make sides active.
TEST(DualActiveSetTest, StructuredHessiansAgreeWithTheInteriorPoint) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 21;
  const auto block_diagonal = [&](const std::vector<int>& sizes) {
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
    int at = 0;
    for (const int size : sizes) {
      Eigen::MatrixXd M(size, size);
      for (Eigen::Index i = 0; i < M.size(); ++i) M.data()[i] = u(rng);
      H.block(at, at, size, size) = M * M.transpose() + Eigen::MatrixXd::Identity(size, size);
      at += size;
    }
    return H;
  };
  std::vector<Eigen::MatrixXd> hessians;
  hessians.push_back(block_diagonal({5, 1, 7, 3, 1, 4}));
  Eigen::MatrixXd joined = block_diagonal({6, 6, 1, 8});
  joined(14, 3) = joined(3, 14) = 0.3;  // fill-in from the first block into the third
  hessians.push_back(joined);
  Eigen::MatrixXd arrow = block_diagonal(std::vector<int>(n, 1));
  arrow.row(n - 1).head(n - 1).setConstant(0.1);
  arrow.col(n - 1).head(n - 1).setConstant(0.1);
  arrow(n - 1, n - 1) = 10.0;
  hessians.push_back(arrow);
  Eigen::MatrixXd band = 3.0 * Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; i + 1 < n; ++i) band(i, i + 1) = band(i + 1, i) = -1.0;
  hessians.push_back(band);
  hessians.push_back(block_diagonal({1, 1, 19}));
  int compared = 0, active = 0;
  for (const Eigen::MatrixXd& H : hessians) {
    QpSolver fast({.method = QpMethod::kActiveSet});
    QpSolver reference({.warm_start = false});
    for (int trial = 0; trial < 10; ++trial) {
      QpProblem q;
      q.H = H;
      q.f = Eigen::VectorXd::NullaryExpr(n, [&](Eigen::Index) { return 3.0 * u(rng); });
      q.lb = Eigen::VectorXd::Constant(n, -0.8);
      q.ub = Eigen::VectorXd::Constant(n, 0.8);
      q.G = Eigen::MatrixXd::NullaryExpr(12, n, [&](Eigen::Index, Eigen::Index) { return u(rng); });
      q.lg = Eigen::VectorXd::Constant(12, -0.5);
      q.ug = Eigen::VectorXd::Constant(12, 0.5);
      q.A.resize(0, n);
      for (int pass = 0; pass < 2; ++pass) {  // cold (or hot from the last trial), then hot
        const QpResult& r = fast.solve(q);
        ASSERT_EQ(r.status, QpStatus::kSolved) << compared;
        EXPECT_EQ(r.method, QpMethod::kActiveSet);
        const Eigen::VectorXd z = r.z;
        active += static_cast<int>((r.dual_rows.array() != 0.0).count() +
                                   (r.dual_bounds.array() != 0.0).count());
        const QpResult& ref = reference.solve(q);
        ASSERT_EQ(ref.status, QpStatus::kSolved);
        EXPECT_LE(inf_norm(z - ref.z), 1e-7) << compared;
        ++compared;
      }
      // The same problem from its own working set takes the fast path, whose one
      // factorization and triangular solves give the optimum directly.
      DualActiveSet direct;
      direct.resize(n, 12, 0);
      ASSERT_EQ(direct.solve(q, false, 200, 1e-10), ActiveSetOutcome::kSolved);
      ASSERT_EQ(direct.solve(q, true, 200, 1e-10), ActiveSetOutcome::kSolved);
      EXPECT_TRUE(direct.took_fast_path()) << compared;
      EXPECT_LE(inf_norm(direct.z() - reference.solve(q).z), 1e-7) << compared;
    }
  }
  EXPECT_EQ(compared, 100);
  EXPECT_GT(active, 200);  // the rows and bounds do bind
}

TEST(DualActiveSetTest, HotStartedSolveDoesNotAllocate) {
  if (!kCountingMalloc) GTEST_SKIP() << "malloc is interposed by the sanitizer";
  TrackingSequence sequence;
  QpSolver solver({.method = QpMethod::kActiveSet});
  g_allocations = 0;
  g_counting = true;
  const QpStatus first = solver.solve(sequence.at(0)).status;
  g_counting = false;
  ASSERT_EQ(first, QpStatus::kSolved);
  ASSERT_GT(g_allocations.load(), 0);  // the counter works: the first solve sizes the workspace
  // 200 steps: besides fast-path solves, some whose working set changes (dual iterations).
  for (int step = 1; step < 200; ++step) {
    const QpProblem& q = sequence.at(step);  // data prepared before counting
    g_allocations = 0;
    g_counting = true;
    const QpStatus status = solver.solve(q).status;
    g_counting = false;
    EXPECT_EQ(status, QpStatus::kSolved);
    EXPECT_EQ(g_allocations.load(), 0) << "step " << step;
  }
}

// z₁ ≥ 1 and z₂ ≥ 1 (bounds) against the row z₁ + z₂ ≤ 1: infeasible. The certificate is
// w = (1, 1, 1) on (z₁ ≥ 1, z₂ ≥ 1, −z₁ − z₂ ≥ −1): Σ wᵢnᵢ = 0, wᵀb = 1 > 0.
TEST(DualActiveSetTest, ConflictingBoundsAndRowAreReportedInfeasible) {
  QpProblem q;
  q.H = Eigen::Matrix2d::Identity();
  q.f = Eigen::Vector2d(0.0, 0.0);
  q.lb = Eigen::Vector2d(1.0, 1.0);
  q.ub = Eigen::Vector2d(kInfinity, kInfinity);
  q.G = Eigen::RowVector2d(1.0, 1.0);
  q.lg = Eigen::VectorXd::Constant(1, -kInfinity);
  q.ug = Eigen::VectorXd::Constant(1, 1.0);
  q.A.resize(0, 2);
  QpSolver solver({.method = QpMethod::kActiveSet});
  const QpResult& r = solver.solve(q);
  EXPECT_EQ(r.status, QpStatus::kPrimalInfeasible) << to_string(r.status);
  EXPECT_EQ(r.method, QpMethod::kActiveSet);
  EXPECT_LE(r.iterations, 4);  // two bounds added, the row found dependent: a few updates

  // A fixed variable (lb = ub = 2) against the row z₁ ≤ 1.
  q.lb = Eigen::Vector2d(2.0, -kInfinity);
  q.ub = Eigen::Vector2d(2.0, kInfinity);
  q.G = Eigen::RowVector2d(1.0, 0.0);
  EXPECT_EQ(solver.solve(q).status, QpStatus::kPrimalInfeasible);

  // After infeasible instances the next feasible one is solved (the hot start is not stale).
  q.ug[0] = 3.0;
  const QpResult& ok = solver.solve(q);
  ASSERT_EQ(ok.status, QpStatus::kSolved);
  EXPECT_NEAR(ok.z[0], 2.0, 1e-12);
  EXPECT_NEAR(ok.z[1], 0.0, 1e-12);
}

// min ½‖z − (3, 3)‖² with the rows z₁ ≤ 1 and z₂ ≤ 1 (both active at z = (1, 1)). The next
// problem inserts an inactive row z₁ + z₂ ≤ 100 before them: told the renumbering, the hot
// start is the optimal working set (no update); read by position it starts from the new row
// and needs updates. Both answer z = (1, 1).
TEST(DualActiveSetTest, RenumberedRowsKeepTheHotStart) {
  QpProblem q;
  q.H = Eigen::Matrix2d::Identity();
  q.f = Eigen::Vector2d(-3.0, -3.0);
  q.G = Eigen::Matrix2d::Identity();
  q.lg = Eigen::Vector2d::Constant(-kInfinity);
  q.ug = Eigen::Vector2d(1.0, 1.0);
  q.A.resize(0, 2);
  QpProblem inserted = q;
  inserted.G.resize(3, 2);
  inserted.G << 1.0, 1.0, 1.0, 0.0, 0.0, 1.0;
  inserted.lg = Eigen::Vector3d::Constant(-kInfinity);
  inserted.ug = Eigen::Vector3d(100.0, 1.0, 1.0);
  for (const bool renumber : {true, false}) {
    QpSolver solver({.method = QpMethod::kActiveSet});
    ASSERT_EQ(solver.solve(q).status, QpStatus::kSolved);
    const int new_row_of_old[] = {1, 2};
    if (renumber) solver.renumber_rows(new_row_of_old);
    const QpResult& r = solver.solve(inserted);
    ASSERT_EQ(r.status, QpStatus::kSolved);
    EXPECT_EQ(r.method, QpMethod::kActiveSet);
    EXPECT_NEAR(r.z[0], 1.0, 1e-12);
    EXPECT_NEAR(r.z[1], 1.0, 1e-12);
    if (renumber) {
      EXPECT_EQ(r.active_set_iterations, 0);
    } else {
      EXPECT_GT(r.active_set_iterations, 0);
    }
  }
}

// H = diag(1, 0) is only semidefinite: the active set cannot factor it and the interior point
// answers, which the result says. min ½z₁² − z₂ with z₂ ≤ 3: z = (0, 3), objective −3.
TEST(DualActiveSetTest, SemidefiniteHessianFallsBackToTheInteriorPoint) {
  QpProblem q;
  q.H = Eigen::Vector2d(1.0, 0.0).asDiagonal();
  q.f = Eigen::Vector2d(0.0, -1.0);
  q.lb = Eigen::Vector2d(-kInfinity, -kInfinity);
  q.ub = Eigen::Vector2d(kInfinity, 3.0);
  q.G.resize(0, 2);
  q.A.resize(0, 2);
  QpSolver solver({.method = QpMethod::kActiveSet});
  const QpResult& r = solver.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_TRUE(r.fell_back);
  EXPECT_EQ(r.method, QpMethod::kInteriorPoint);
  EXPECT_NEAR(r.objective, -3.0, 1e-8);
  EXPECT_NEAR(r.z[1], 3.0, 1e-8);
}

// With a cap of 2 updates a cold solve that needs many cannot finish in the active set; the
// interior point answers the same optimum (never a capped iterate called solved).
TEST(DualActiveSetTest, IterationCapFallsBackToTheSameOptimum) {
  TrackingSequence sequence;
  const QpProblem& q = sequence.at(0);
  QpSolver uncapped({.method = QpMethod::kActiveSet});
  const QpResult& full = uncapped.solve(q);
  ASSERT_EQ(full.status, QpStatus::kSolved);
  ASSERT_GT(full.active_set_iterations, 2);
  const Eigen::VectorXd z = full.z;
  QpSolver capped({.method = QpMethod::kActiveSet, .active_set_max_iterations = 2});
  const QpResult& r = capped.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_TRUE(r.fell_back);
  EXPECT_EQ(r.active_set_iterations, 3);  // stopped at the first update beyond the cap
  EXPECT_LE(inf_norm(r.z - z), 1e-7);
}

// The multipliers follow QpResult's convention (+ upper side, − lower side) like the interior
// point's: min ½‖z‖² − 2z₁ + 2z₂ + z₃ with −1 ≤ z ≤ 1 and the row z₃ ≥ 0.5:
// z = (1, −1, 0.5); bound multipliers (+1, −1, 0) (z₁ − 2 + w₁ = 0 → w₁ = 1), row −1.5.
TEST(DualActiveSetTest, MultipliersHaveTheInteriorPointsSigns) {
  QpProblem q;
  q.H = Eigen::Matrix3d::Identity();
  q.f = Eigen::Vector3d(-2.0, 2.0, 1.0);
  q.lb = Eigen::Vector3d::Constant(-1.0);
  q.ub = Eigen::Vector3d::Constant(1.0);
  q.G = Eigen::RowVector3d(0.0, 0.0, 1.0);
  q.lg = Eigen::VectorXd::Constant(1, 0.5);
  q.ug = Eigen::VectorXd::Constant(1, kInfinity);
  q.A.resize(0, 3);
  QpSolver fast({.method = QpMethod::kActiveSet});
  const QpResult& r = fast.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_EQ(r.method, QpMethod::kActiveSet);
  EXPECT_LE(inf_norm(r.z - Eigen::Vector3d(1.0, -1.0, 0.5)), 1e-12);
  EXPECT_LE(inf_norm(r.dual_bounds - Eigen::Vector3d(1.0, -1.0, 0.0)), 1e-12);
  EXPECT_NEAR(r.dual_rows[0], -1.5, 1e-12);
  EXPECT_NEAR(r.objective, 0.5 * 2.25 - 2.0 - 2.0 + 0.5, 1e-12);
  EXPECT_EQ(r.duality_gap, 0.0);
}

// most_violated() tests the rows four at a time before it tests a few in full, and skips the
// trailing rows free on both sides (the MPC's padding of its soft rows): one row violated by
// the unconstrained minimum, at every position of every row count up to 13, on its lower or
// upper side, with and without free rows after it (whose G is not zero), must be found and made
// active; hot-started from the case before, as in the MPC.
TEST(DualActiveSetTest, AViolatedRowIsFoundAtEveryPositionBeforeFreeRows) {
  QpSettings settings;
  settings.method = QpMethod::kActiveSet;
  QpSolver solver(settings);
  const Eigen::Vector3d target(1.0, 2.0, 3.0);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> any(-1.0, 1.0);
  for (int m = 1; m <= 13; ++m) {
    for (int i = 0; i < m; ++i) {
      for (const bool lower : {true, false}) {
        for (const int free_rows : {0, 5}) {
          QpProblem q;
          q.H = 2.0 * Eigen::Matrix3d::Identity();
          q.f = -2.0 * target;  // unconstrained minimum: z = target
          q.A.resize(0, 3);
          q.G = Eigen::MatrixXd::Zero(m + free_rows, 3);
          q.lg = Eigen::VectorXd::Constant(m + free_rows, -100.0);
          q.ug = Eigen::VectorXd::Constant(m + free_rows, 100.0);
          for (int j = 0; j < m; ++j) q.G(j, j % 3) = 1.0;
          const int k = i % 3;
          Eigen::Vector3d expected = target;
          if (lower) {
            q.lg[i] = target[k] + 0.5;  // z_k ≥ target_k + 0.5
            expected[k] += 0.5;
          } else {
            q.ug[i] = target[k] - 0.5;  // z_k ≤ target_k − 0.5
            expected[k] -= 0.5;
          }
          for (int j = m; j < m + free_rows; ++j) {
            for (int c = 0; c < 3; ++c) q.G(j, c) = any(rng);
            q.lg[j] = -kInfinity;
            q.ug[j] = kInfinity;
          }
          const QpResult& r = solver.solve(q);
          SCOPED_TRACE(::testing::Message() << "m " << m << " row " << i << " lower " << lower
                                            << " free rows " << free_rows);
          ASSERT_EQ(r.status, QpStatus::kSolved);
          EXPECT_FALSE(r.fell_back);
          EXPECT_LT((r.z - expected).cwiseAbs().maxCoeff(), 1e-9);
          // Only row i holds a multiplier (negative on a lower side, as the interior point's).
          for (int j = 0; j < m + free_rows; ++j) {
            if (j == i) {
              EXPECT_NEAR(r.dual_rows[j], lower ? -1.0 : 1.0, 1e-9);
            } else {
              EXPECT_EQ(r.dual_rows[j], 0.0) << j;
            }
          }
        }
      }
    }
  }
  // Free rows only (no row has a finite side): the unconstrained minimum, no multiplier.
  QpProblem q;
  q.H = 2.0 * Eigen::Matrix3d::Identity();
  q.f = -2.0 * target;
  q.A.resize(0, 3);
  q.G = Eigen::MatrixXd::Ones(5, 3);
  q.lg = Eigen::VectorXd::Constant(5, -kInfinity);
  q.ug = Eigen::VectorXd::Constant(5, kInfinity);
  const QpResult& r = solver.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_LT((r.z - target).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(r.dual_rows.cwiseAbs().maxCoeff(), 0.0);
}

// The active set checks G's entries through the product G·z it ends with, not by a pass of its
// own (QpSolver::solve): a NaN or an infinity anywhere in G must still be rejected, in a row of
// the hot start's working set (read first by the fast path), in an inactive row, at an entry
// whose variable is zero at the solution (∞·0), and in the free rows after the others that the
// solve skips. After each rejection the valid problem is solved as before.
TEST(DualActiveSetTest, ANonFiniteRowEntryIsRejectedWhereverItIs) {
  TrackingSequence sequence;
  QpProblem q = sequence.at(3);
  const int n = static_cast<int>(q.H.rows()), rows = static_cast<int>(q.G.rows());
  constexpr int kFreeRows = 6;
  q.G.conservativeResize(rows + kFreeRows, n);
  q.lg.conservativeResize(rows + kFreeRows);
  q.ug.conservativeResize(rows + kFreeRows);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> any(-1.0, 1.0);
  for (int j = rows; j < rows + kFreeRows; ++j) {
    for (int c = 0; c < n; ++c) q.G(j, c) = any(rng);
    q.lg[j] = -kInfinity;
    q.ug[j] = kInfinity;
  }
  QpSolver solver({.method = QpMethod::kActiveSet});
  const QpResult& first = solver.solve(q);
  ASSERT_EQ(first.status, QpStatus::kSolved);
  ASSERT_FALSE(first.fell_back);
  const Eigen::VectorXd z = first.z, dual_rows = first.dual_rows;
  int active_rows = 0, zero_variables = 0;
  for (int j = 0; j < rows + kFreeRows; ++j) {
    const bool active = dual_rows[j] != 0.0;
    active_rows += active ? 1 : 0;
    for (const int c : {j % n, (7 * j + 3) % n}) {
      zero_variables += z[c] == 0.0 ? 1 : 0;
      for (const double v : {std::nan(""), kInfinity, -kInfinity}) {
        ASSERT_EQ(solver.solve(q).status, QpStatus::kSolved);  // hot start: row j in it if active
        QpProblem bad = q;
        bad.G(j, c) = v;
        EXPECT_EQ(solver.solve(bad).status, QpStatus::kInvalidInput)
            << "row " << j << " column " << c << " value " << v << " active " << active;
      }
    }
  }
  EXPECT_GT(active_rows, 3);  // the working set's rows were among those spoiled
  const QpResult& again = solver.solve(q);
  ASSERT_EQ(again.status, QpStatus::kSolved);
  EXPECT_LT(inf_norm(again.z - z), 1e-12);
  RecordProperty("zero_variables", zero_variables);

  // ∞ against a variable that is exactly zero at the solution (∞·0 is NaN), and a finite G
  // whose product overflows (a free row of 1e308 before a live row): the first is rejected, the
  // second is not (G is checked in full when the product is not finite).
  QpProblem small;
  small.H = 2.0 * Eigen::Matrix2d::Identity();
  small.f = Eigen::Vector2d(-4.0, 0.0);  // z = (2, 0)
  small.G = Eigen::Matrix2d::Identity();
  small.lg = Eigen::Vector2d(-kInfinity, -kInfinity);
  small.ug = Eigen::Vector2d(kInfinity, 5.0);  // row 1 live, inactive
  small.A.resize(0, 2);
  QpSolver two({.method = QpMethod::kActiveSet});
  ASSERT_EQ(two.solve(small).status, QpStatus::kSolved);
  ASSERT_EQ(two.last_result().z[1], 0.0);
  QpProblem spoiled = small;
  spoiled.G(1, 1) = kInfinity;
  EXPECT_EQ(two.solve(spoiled).status, QpStatus::kInvalidInput);
  EXPECT_EQ(two.last_result().iterations, 0);
  QpProblem huge = small;
  huge.G(0, 0) = 1e308;  // 1e308 · 2 overflows in the product
  const QpResult& big = two.solve(huge);
  EXPECT_EQ(big.status, QpStatus::kSolved);
  EXPECT_LT(inf_norm(big.z - Eigen::Vector2d(2.0, 0.0)), 1e-12);
}

// More equality rows than variables (consistent: z = 0 twice): the fast path leaves them to
// the dual method, which keeps the independent one, instead of writing past its working set.
TEST(DualActiveSetTest, MoreEqualitiesThanVariablesAreSolved) {
  QpProblem q;
  q.H = Eigen::Matrix<double, 1, 1>(1.0);
  q.f = Eigen::Matrix<double, 1, 1>(-1.0);
  q.G.resize(0, 1);
  q.A = Eigen::Vector2d(1.0, 1.0);
  q.b = Eigen::Vector2d(0.0, 0.0);
  QpSolver solver({.method = QpMethod::kActiveSet});
  for (int pass = 0; pass < 2; ++pass) {
    const QpResult& r = solver.solve(q);
    ASSERT_EQ(r.status, QpStatus::kSolved) << pass;
    EXPECT_NEAR(r.z[0], 0.0, 1e-12);
  }
}

// The fast path corrects a guessed working set that is one side off: a side that became
// violated joins it, a side whose multiplier turned negative leaves it, and the range-space
// solve is repeated (one update each, no dual method). z = clamp(target, −∞, 1) on a box of
// rows z_i ≤ 1 and H = 2I: the working set is the rows whose target exceeds 1.
TEST(DualActiveSetTest, AGuessOneSideOffIsCorrectedByTheFastPath) {
  // Variables 8–11 carry the equalities, which every working set holds and no correction may
  // drop: row 8 is z_8 + z_9 = 0.5 (lg = ug), variable 10 is fixed at −0.2 (lb = ub), row 9 is
  // the equality row z_11 = 0.3 of A.
  const int n = 12, rows = 9;
  QpProblem q;
  q.H = 2.0 * Eigen::MatrixXd::Identity(n, n);
  q.lb = Eigen::VectorXd::Constant(n, -10.0);
  q.ub = Eigen::VectorXd::Constant(n, 10.0);
  q.lb[10] = q.ub[10] = -0.2;
  q.G = Eigen::MatrixXd::Zero(rows, n);
  q.G.leftCols(8).topRows(8).setIdentity();
  q.G(8, 8) = q.G(8, 9) = 1.0;
  q.lg = Eigen::VectorXd::Constant(rows, -kInfinity);
  q.ug = Eigen::VectorXd::Constant(rows, 1.0);
  q.lg[8] = q.ug[8] = 0.5;
  q.A = Eigen::MatrixXd::Zero(1, n);
  q.A(0, 11) = 1.0;
  q.b = Eigen::VectorXd::Constant(1, 0.3);
  DualActiveSet solver;
  solver.resize(n, rows, 1);
  const int equalities = 3;
  // (target, the working set's size, updates of the hot-started solve)
  struct Case {
    Eigen::VectorXd target;
    int active, updates;
  };
  Eigen::VectorXd t(n);
  std::vector<Case> cases;
  t << 2.0, 3.0, 0.5, 0.2, 0.1, 0.0, -1.0, 0.3, 0.0, 0.0, 0.0, 0.0;
  cases.push_back({t, 2, -1});  // the cold start
  t[2] = 1.5;                   // row 2 becomes violated: it joins
  cases.push_back({t, 3, 1});
  t[0] = 0.5;  // row 0's multiplier turns negative: it leaves
  cases.push_back({t, 2, 1});
  t[0] = 0.4;  // the same working set: the fast path as it is
  cases.push_back({t, 2, 0});
  t[3] = 1.2;  // one joins and one leaves (row 1's target drops below 1)
  t[1] = 0.9;
  cases.push_back({t, 2, 2});
  for (std::size_t c = 0; c < cases.size(); ++c) {
    SCOPED_TRACE(c);
    q.f = -2.0 * cases[c].target;
    ASSERT_EQ(solver.solve(q, c > 0, 100, 1e-10), ActiveSetOutcome::kSolved);
    Eigen::VectorXd expected = cases[c].target.cwiseMin(1.0);
    expected.tail(4) << 0.25, 0.25, -0.2, 0.3;  // the equalities (targets 0: z_8 = z_9)
    EXPECT_LT(inf_norm(solver.z() - expected), 1e-12);
    EXPECT_EQ(solver.working_set_size(), equalities + cases[c].active);
    if (cases[c].updates >= 0) {
      EXPECT_EQ(solver.iterations(), cases[c].updates);
      EXPECT_TRUE(solver.took_fast_path());  // no dual method
    }
  }
  // Corrections count against the iteration cap: with one allowed, the last case's two
  // changes are not made by the fast path (the dual method drops the side that left while it
  // makes its start dual feasible, then adds one), and the answer is the same optimum.
  QpSolver capped({.method = QpMethod::kActiveSet, .active_set_max_iterations = 1});
  q.f = -2.0 * cases[3].target;
  ASSERT_EQ(capped.solve(q).status, QpStatus::kSolved);
  q.f = -2.0 * cases[4].target;
  const QpResult& r = capped.solve(q);
  ASSERT_EQ(r.status, QpStatus::kSolved);
  EXPECT_LE(r.active_set_iterations, 1);
  Eigen::VectorXd expected = cases[4].target.cwiseMin(1.0);
  expected.tail(4) << 0.25, 0.25, -0.2, 0.3;
  EXPECT_LT(inf_norm(r.z - expected), 1e-7);
}

TEST(DualActiveSetTest, CorrectionsOfALargeWorkingSetKeepTheFastPath) {
  // Working sets of more than half the variables, with a coupled H (so that Y = L⁻¹N is full
  // and the Gram matrix YᵀY has off-diagonal entries), corrected by the fast path: a side
  // leaves from the middle of the working set (the last one takes its place, and the Gram
  // matrix's factor is computed again from that row), a side joins (one row appended), both,
  // and five changes at once; each answer equals a cold solve's (the dual method's).
  const int n = 10, rows = 9;
  QpProblem q;
  q.H = 2.0 * Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; i + 1 < n; ++i) q.H(i, i + 1) = q.H(i + 1, i) = 0.3;
  q.lb = Eigen::VectorXd::Constant(n, -10.0);
  q.ub = Eigen::VectorXd::Constant(n, 10.0);
  q.G = Eigen::MatrixXd::Zero(rows, n);
  q.G.leftCols(rows).setIdentity();  // z_i ≤ 1 for i < 9
  q.lg = Eigen::VectorXd::Constant(rows, -kInfinity);
  q.ug = Eigen::VectorXd::Constant(rows, 1.0);
  DualActiveSet solver;
  solver.resize(n, rows, 0);
  // (targets of the unconstrained minimizer, the working set's size, the fast path's updates)
  struct Case {
    Eigen::VectorXd target;
    int active, updates;
  };
  Eigen::VectorXd t(n);
  std::vector<Case> cases;
  t << 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, -2.0, -2.0, 0.0;
  cases.push_back({t, 7, -1});  // the cold start: rows 0–6 active, 7 > n/2
  t[2] = -2.0;                  // row 2, in the middle of the working set, leaves
  cases.push_back({t, 6, 1});
  t[8] = 3.0;  // row 8 joins (at the end)
  cases.push_back({t, 7, 1});
  t[4] = -2.0;  // one leaves, one joins
  t[7] = 3.0;
  cases.push_back({t, 7, 2});
  t[0] = t[1] = t[3] = -2.0;  // three leave, two join: five changes
  t[2] = 3.0;
  t[4] = 3.0;
  cases.push_back({t, 6, 5});
  for (std::size_t c = 0; c < cases.size(); ++c) {
    SCOPED_TRACE(c);
    q.f = -q.H * cases[c].target;
    ASSERT_EQ(solver.solve(q, c > 0, 100, 1e-10), ActiveSetOutcome::kSolved);
    DualActiveSet cold;
    cold.resize(n, rows, 0);
    ASSERT_EQ(cold.solve(q, false, 100, 1e-10), ActiveSetOutcome::kSolved);
    EXPECT_LT(inf_norm(solver.z() - cold.z()), 1e-12);
    EXPECT_LE(solver.z().head(rows).maxCoeff(), 1.0 + 1e-12);
    EXPECT_EQ(solver.working_set_size(), cases[c].active);
    if (cases[c].updates >= 0) {
      EXPECT_EQ(solver.iterations(), cases[c].updates);
      EXPECT_TRUE(solver.took_fast_path());  // no dual method
    }
  }
}

TEST(DualActiveSetTest, ASideJoiningInTheSpanOfTheWorkingSetIsSwappedIn) {
  // z_0 ≤ 1, z_1 ≤ 1 and z_0 + z_1 ≤ c: with c = 2.5 the first two are the working set; with
  // c = 1.5 the third joins, and its normal is the sum of theirs (the Gram matrix of the three is
  // singular). The fast path lets the side whose multiplier reaches zero first as the third's
  // grows leave for it: the one with the smaller multiplier, whose target is nearer its bound
  // (the other one's multiplier would turn negative, then the first one come back: four updates
  // instead of two). Both orders of the targets; no dual method; each answer is a cold start's.
  // A side in the span of an equality alone has no side to take the place of.
  const int n = 3, rows = 3;
  for (const bool first_nearer : {true, false}) {
    SCOPED_TRACE(first_nearer);
    const Eigen::Vector3d target =
        first_nearer ? Eigen::Vector3d(3.0, 4.0, -0.5) : Eigen::Vector3d(4.0, 3.0, -0.5);
    QpProblem q;
    q.H = 2.0 * Eigen::MatrixXd::Identity(n, n);
    q.f = -2.0 * target;
    q.lb = Eigen::VectorXd::Constant(n, -10.0);
    q.ub = Eigen::VectorXd::Constant(n, 10.0);
    q.G = Eigen::MatrixXd::Zero(rows, n);
    q.G(0, 0) = q.G(1, 1) = q.G(2, 0) = q.G(2, 1) = 1.0;
    q.lg = Eigen::VectorXd::Constant(rows, -kInfinity);
    q.ug = Eigen::Vector3d(1.0, 1.0, 2.5);
    DualActiveSet solver;
    solver.resize(n, rows, 0);
    // The first solve with the same targets in both cases, so that the side that must leave
    // is the first of the working set in one case and the second in the other.
    q.f = -2.0 * Eigen::Vector3d(4.0, 3.0, -0.5);
    ASSERT_EQ(solver.solve(q, false, 100, 1e-10), ActiveSetOutcome::kSolved);
    EXPECT_LT(inf_norm(solver.z() - Eigen::Vector3d(1.0, 1.0, -0.5)), 1e-12);
    ASSERT_EQ(solver.working_set_size(), 2);
    q.f = -2.0 * target;
    q.ug[2] = 1.5;
    ASSERT_EQ(solver.solve(q, true, 100, 1e-10), ActiveSetOutcome::kSolved);
    // The side at its bound stays (the farther target), the sum takes the rest.
    const Eigen::Vector3d expected =
        first_nearer ? Eigen::Vector3d(0.5, 1.0, -0.5) : Eigen::Vector3d(1.0, 0.5, -0.5);
    EXPECT_LT(inf_norm(solver.z() - expected), 1e-12);
    EXPECT_EQ(solver.working_set_size(), 2);
    EXPECT_EQ(solver.iterations(), 2);  // the third joins, one leaves for it
    EXPECT_TRUE(solver.took_fast_path());
    DualActiveSet cold;
    cold.resize(n, rows, 0);
    ASSERT_EQ(cold.solve(q, false, 100, 1e-10), ActiveSetOutcome::kSolved);
    EXPECT_LT(inf_norm(cold.z() - solver.z()), 1e-12);
  }
  // A side that joins in the span of an equality alone (z_0 + z_1 = 1 held, z_0 + z_1 ≤ 0.5
  // joining): no side may leave for it, and the dual method proves the problem infeasible.
  QpProblem q;
  q.H = 2.0 * Eigen::MatrixXd::Identity(n, n);
  q.f = Eigen::Vector3d(-2.0, -2.0, 0.0);
  q.lb = Eigen::VectorXd::Constant(n, -10.0);
  q.ub = Eigen::VectorXd::Constant(n, 10.0);
  q.G = Eigen::MatrixXd::Zero(2, n);
  q.G(0, 0) = q.G(0, 1) = q.G(1, 0) = q.G(1, 1) = 1.0;
  q.lg = Eigen::Vector2d(1.0, -kInfinity);
  q.ug = Eigen::Vector2d(1.0, 2.0);
  DualActiveSet solver;
  solver.resize(n, 2, 0);
  ASSERT_EQ(solver.solve(q, false, 100, 1e-10), ActiveSetOutcome::kSolved);
  q.ug[1] = 0.5;
  EXPECT_EQ(solver.solve(q, true, 100, 1e-10), ActiveSetOutcome::kInfeasible);
  EXPECT_FALSE(solver.took_fast_path());
}

}  // namespace
}  // namespace ridgeline::qp
