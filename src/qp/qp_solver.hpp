// Dense convex QP solver: primal–dual interior point with Mehrotra predictor–corrector
// (DESIGN §3, the paper's "primal–dual method").
//
//   minimize    ½ zᵀ H z + fᵀ z
//   subject to  lb ≤ z ≤ ub            (box bounds, ±infinity allowed)
//               lg ≤ G z ≤ ug          (two-sided general rows, ±infinity allowed)
//               A z = b                (optional equality rows)
//
// H must be symmetric positive semidefinite. Sized for MPC: tens of variables, hundreds of
// rows, solved every control period and warm-started from the previous solution. After the
// first solve of a given size, solve() allocates nothing.
#pragma once

#include <limits>
#include <memory>
#include <span>
#include <string_view>

#include <Eigen/Core>

namespace ridgeline::qp {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// Problem data. Sizes: n variables, m general rows, p equality rows (all may be zero
/// except n). Unbounded sides are ±kInfinity.
struct QpProblem {
  Eigen::MatrixXd H;   ///< n×n, symmetric PSD
  Eigen::VectorXd f;   ///< n
  Eigen::VectorXd lb;  ///< n (or empty: no bounds)
  Eigen::VectorXd ub;  ///< n (or empty: no bounds)
  Eigen::MatrixXd G;   ///< m×n
  Eigen::VectorXd lg;  ///< m
  Eigen::VectorXd ug;  ///< m
  Eigen::MatrixXd A;   ///< p×n
  Eigen::VectorXd b;   ///< p

  int num_variables() const { return static_cast<int>(H.rows()); }
};

enum class QpStatus {
  kSolved,            ///< optimal within tolerances
  kIterationLimit,    ///< stopped at max_iterations; the iterate is not certified optimal
  kPrimalInfeasible,  ///< no z satisfies the constraints (certificate found)
  kDualInfeasible,    ///< objective unbounded below on the feasible set (certificate found)
  kNumericalError,    ///< factorization failed or the iteration broke down
  kInvalidInput,      ///< sizes inconsistent, NaN/inf in data, lower side above upper side
};
std::string_view to_string(QpStatus status);

/// The algorithm QpSolver runs.
enum class QpMethod {
  /// Primal–dual interior point (Mehrotra), with polishing: any convex QP.
  kInteriorPoint,
  /// Goldfarb–Idnani dual active set (dual_active_set.hpp), hot-started from the previous
  /// solve's working set, with O(n²) factor updates per added or dropped side; the interior
  /// point is the fallback when H is not strictly convex, the iteration cap is reached or a
  /// check of the result fails. For MPC: exact active-set solutions in a few updates.
  kActiveSet,
};
std::string_view to_string(QpMethod method);

/// Solver options with documented defaults.
struct QpSettings {
  int max_iterations = 100;
  double tolerance = 1e-9;             ///< relative KKT tolerance (residuals and gap)
  double infeasibility_tolerance = 1e-8;
  bool warm_start = true;              ///< start from the previous solution when sizes match
  /// A warm-started solve that has not converged after this many iterations restarts cold
  /// (a far-off previous solution can cost more than a cold start).
  int warm_start_max_iterations = 25;
  /// After kSolved, solve the equality-constrained QP on the active set guessed from the
  /// interior point (a side is active when its multiplier exceeds its slack; the solve is
  /// refined from the interior point's z and multipliers, which keeps the multipliers
  /// sign-correct when the active rows are dependent) and keep that point when it is
  /// feasible, its multipliers have the right signs and its objective is no worse, all within
  /// `tolerance` (relative). A wrong guess is corrected (sides with wrong-signed multipliers
  /// released, violated sides forced) and solved again, a few times at most. z then is exact
  /// up to round-off instead of ~√μ-accurate on degenerate problems (as OSQP's polishing).
  bool polish = true;
  QpMethod method = QpMethod::kInteriorPoint;
  /// kActiveSet: sides added or dropped (by the dual method, or by the fast path's
  /// corrections of its guessed working set) before falling back to the interior point (a
  /// bounded worst case); 0 means 2·(n + 10).
  int active_set_max_iterations = 0;
};

/// Outcome of one solve. `z` is meaningful for kSolved (and is the last iterate otherwise).
struct QpResult {
  QpStatus status = QpStatus::kInvalidInput;
  Eigen::VectorXd z;             ///< primal solution, n
  Eigen::VectorXd dual_bounds;   ///< multipliers of the box bounds (+ upper, − lower), n
  Eigen::VectorXd dual_rows;     ///< multipliers of the general rows (+ upper, − lower), m
  Eigen::VectorXd dual_eq;       ///< multipliers of the equality rows, p
  int iterations = 0;
  double objective = 0.0;        ///< ½zᵀHz + fᵀz
  double primal_residual = 0.0;  ///< max constraint violation (∞-norm)
  double dual_residual = 0.0;    ///< ∞-norm of the Lagrangian's gradient
  double duality_gap = 0.0;
  double solve_time_us = 0.0;
  bool polished = false;         ///< the polished active-set point replaced the interior point
  QpMethod method = QpMethod::kInteriorPoint;  ///< the method whose answer this is
  bool fell_back = false;        ///< kActiveSet was asked for and the interior point answered
  int active_set_iterations = 0; ///< of kActiveSet (included in `iterations`)
};

class QpSolver {
 public:
  explicit QpSolver(QpSettings settings = {});

  /// Solves the problem; warm-starts from the previous solve when enabled and sizes match.
  const QpResult& solve(const QpProblem& problem);
  /// Forgets the previous solution (the next solve starts cold).
  void reset();
  /// The general rows of the next problem are those of the last one renumbered: old row j is
  /// row new_row_of_old[j] (−1: gone; the span has the last problem's m entries). The
  /// active-set method's hot start follows its rows instead of reading their old indices as
  /// other rows (for an MPC whose soft rows come and go along the horizon). The interior
  /// point's warm start is left as it is.
  void renumber_rows(std::span<const int> new_row_of_old);

  const QpSettings& settings() const { return settings_; }
  const QpResult& last_result() const { return result_; }

 private:
  bool solve_active_set(const QpProblem& problem);

  QpSettings settings_;
  QpResult result_;
  // The solver's workspace lives in the implementation file.
  struct Workspace;
  struct WorkspaceDeleter {
    void operator()(Workspace*) const;
  };
  std::unique_ptr<Workspace, WorkspaceDeleter> workspace_;
};

}  // namespace ridgeline::qp
