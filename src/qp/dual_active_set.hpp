// Goldfarb–Idnani dual active-set method for strictly convex dense QPs: the fast path of
// QpSolver (QpMethod::kActiveSet), hot-started from the previous solve's working set.
//
// Every finite side is a one-sided constraint nᵀz ≥ b with normal n and value b:
//   lower bound  e_iᵀz ≥ lb_i,   upper bound  −e_iᵀz ≥ −ub_i,
//   lower row    g_jᵀz ≥ lg_j,   upper row    −g_jᵀz ≥ −ug_j,   equality row a_kᵀz = b_k
// (a row with lg == ug and a variable with lb == ub are equalities too). With H = LLᵀ and the
// working set's normals N (n×q), the method keeps J = L⁻ᵀQ and R (q×q, upper triangular) with
// L⁻¹N = Q₁R, Q = [Q₁ Q₂] orthogonal, J = [J₁ J₂]. Then (Goldfarb & Idnani 1983)
//
//   the equality-constrained minimizer on the working set is
//     z = J₁R⁻ᵀb_A − J₂J₂ᵀf,   multipliers u = R⁻¹(R⁻ᵀb_A + J₁ᵀf),                     (1)
//   and for a violated constraint p, with d = Jᵀn_p = [d₁; d₂],
//     primal step direction s = J₂d₂,   dual step direction r = R⁻¹d₁.                     (2)
//
// The dual method keeps u ≥ 0 on inequalities (dual feasibility) and adds violated
// constraints: the step t along (2) is the smaller of the full step −(n_pᵀz − b_p)/‖d₂‖² that
// makes p active and the partial step min u_j/r_j (r_j > 0) at which a multiplier reaches
// zero (that constraint is dropped). Adding or dropping a constraint updates J and R by Givens
// rotations in O(n²). When d₂ = 0 and no r_j > 0, w = (−r, 1) on (working set, p) is a Farkas
// certificate (Σ wᵢnᵢ = 0, wᵀb > 0): no point satisfies the constraints. The certificate is
// checked numerically before kInfeasible is returned.
//
// Hot start: the previous working set (inequalities whose sides still exist) is factored at
// once; (1) gives its minimizer; constraints with negative multipliers are dropped one at a time
// (most negative first) until u ≥ 0, which is a valid dual-feasible start. On an MPC sequence
// the working set changes little from one period to the next, so a solve is one factorization
// of H, q rank-one updates and a few iterations. Before that, a fast path tries the guessed
// working set by the range-space method and corrects it by up to five sides (see
// try_working_set); it answers most hot starts. The factor of H stops each column at its
// envelope (the last row that can be nonzero), so a block-diagonal H, such as an MPC's with
// inputs no output couples and its slacks, costs its blocks (see cholesky_lower).
//
// All storage is sized by resize(); solve() allocates nothing.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "qp/qp_solver.hpp"

namespace ridgeline::qp {

enum class ActiveSetOutcome {
  kSolved,             ///< primal and dual feasible, complementary; checked on the data
  kInfeasible,         ///< a Farkas certificate was found and checked
  kIterationLimit,     ///< stopped at the iteration cap
  kNotStrictlyConvex,  ///< H is not numerically positive definite (cond ≳ 1e14)
  kNumericalError,     ///< dependent equalities, a failed check of the result
};

/// Storage still to be fetched into the cache, a line at a time (DualActiveSet::solve fetches
/// G's rows ahead of their first use, QpSolver a problem's small arrays at once).
struct LinePrefetch {
  static constexpr std::size_t kLine = 64;  // bytes (x86-64 and the usual arm64 cores)
  const char* base = nullptr;
  std::size_t next = 0, bytes = 0;  // offsets from base: the next line's, and the end
  /// Prefetches the next `lines` lines (a no-op for lines already in the cache).
  void ahead(std::size_t lines) {
    for (std::size_t k = 0; k < lines && next < bytes; ++k, next += kLine) {
      __builtin_prefetch(base + next, 0, 3);
    }
  }
};

class DualActiveSet {
 public:
  /// Sizes the workspace for n variables, up to m general rows and p equality rows; allocates
  /// only when a size grows. Forgets the working set when n or p changes.
  void resize(int n, int m, int p);
  /// Solves `q` (valid input, sized as in resize(); the entries of G may be unchecked: see
  /// row_products()). `hot_start`: start from the working set of
  /// the last kSolved. `tolerance`: feasibility tolerance per side, times max(1, ‖n‖), and the
  /// relative tolerance of the final stationarity check.
  ActiveSetOutcome solve(const QpProblem& q, bool hot_start, int max_iterations,
                         double tolerance);
  /// Forgets the working set (the next solve starts from the unconstrained minimizer).
  void forget() { saved_count_ = 0; }
  /// Takes the working set from signed multipliers in QpResult's convention (a side is in it
  /// when its multiplier's magnitude exceeds `threshold`), e.g. after a fallback solve.
  void set_working_set(const QpResult& result, double threshold);
  /// The general rows were renumbered: old row j is row new_row_of_old[j] of the next problem
  /// (−1: gone). The saved working set follows its rows (a row index outside the map is
  /// dropped), so a hot start keeps its guess when rows are inserted or removed before them.
  void renumber_rows(const int* new_row_of_old, int old_rows);

  const Eigen::VectorXd& z() const { return x_; }
  /// Multipliers in QpResult's convention (+ upper side, − lower side).
  void multipliers(Eigen::VectorXd& dual_bounds, Eigen::VectorXd& dual_rows,
                   Eigen::VectorXd& dual_eq) const;
  /// After kSolved: G·z for the rows with a finite side, [0, live_rows()), the product the solve
  /// ended with; the rows after them are free on both sides, never read. A non-finite entry of
  /// a row makes its product with a finite z non-finite (∞·0 is NaN), so a caller that did not
  /// check G's entries before solve() can check these products instead (QpSolver does).
  const Eigen::VectorXd& row_products() const { return gx_; }
  int live_rows() const { return m_live_; }
  int iterations() const { return iterations_; }
  /// Whether the last solve was answered by the fast path (the range-space solve of the
  /// guessed working set — the last solve's on a hot start, the equalities alone on a cold
  /// one — corrected by iterations() updates, five at most), not by the dual method.
  bool took_fast_path() const { return fast_path_; }
  int working_set_size() const { return count_; }
  double objective() const { return objective_; }
  double primal_residual() const { return primal_residual_; }
  double dual_residual() const { return dual_residual_; }

 private:
  enum Kind : int { kLower = 0, kUpper = 1, kRowLower = 2, kRowUpper = 3, kEqualityRow = 4 };
  struct Side {
    int kind = kLower;
    int index = 0;
  };

  bool is_equality(Side c) const;
  double normal_dot(Side c, const Eigen::VectorXd& v) const;
  double value(Side c) const;
  double norm(Side c) const;
  void add_normal(Side c, double a, Eigen::Ref<Eigen::VectorXd> out) const;  // out += a·n_c
  bool usable(Side c) const;  // a saved side that exists in this problem as an inequality
  void jt_normal(Side c);                                         // d_ = Jᵀn_c
  bool add(Side c);  // adds c to the factorization; false (nothing added) if c is dependent
  void drop(int k);  // removes working-set entry k
  void solve_working_set();  // (1): x_ and u_
  bool most_violated(Side& c, double& violation);
  bool check_certificate(Side p);
  bool finish(bool gx_current);  // objective, residuals, the stationarity check
  bool try_working_set(bool hot_start, int max_iterations);  // the fast path (see the .cpp)

  int n_ = -1, m_ = -1, p_ = -1, m_capacity_ = -1;
  // Rows [0, m_live_) hold every row with a finite side: the rows after them are free on both
  // sides (the MPC's padding of its soft rows), never violated nor active: most_violated()'s
  // product and checks, finish()'s and the scans for equalities skip them (set by solve()).
  int m_live_ = 0;
  LinePrefetch fetch_;
  std::vector<int> candidates_;  // m_capacity_ entries: most_violated()'s rows to test in full
  const QpProblem* q_ = nullptr;
  double tolerance_ = 1e-10;
  Eigen::MatrixXd L_;  // H = LLᵀ, lower triangle (the upper one is unused)
  // 1 / L(j, j), and the same of the fast path's factor of S: the substitutions multiply by
  // them (a division in their chains of dependent operations costs several multiplications).
  Eigen::VectorXd l_inverse_diagonal_, s_inverse_diagonal_;
  std::vector<int> l_end_;  // L_'s envelope: one past each column's last row that can be nonzero
  Eigen::MatrixXd J_, R_;
  Eigen::VectorXd x_, u_, d_, step_, r_, jtf_, v_, hx_, res_, gx_;
  // The fast path's Y = L⁻¹N, its Gram matrix YᵀY (lower triangle) and the Gram matrix's
  // Cholesky factor S, kept apart so that a correction forms only what changed.
  Eigen::MatrixXd Y_, gram_, S_;
  Eigen::VectorXd dual_bounds_, dual_eq_;
  // Working set: count_ entries; saved_ is the working set of the last kSolved (for hot start).
  std::vector<Side> active_, saved_;
  int count_ = 0, saved_count_ = 0;
  int iterations_ = 0;
  bool fast_path_ = false;
  double objective_ = 0.0, primal_residual_ = 0.0, dual_residual_ = 0.0;
};

}  // namespace ridgeline::qp
