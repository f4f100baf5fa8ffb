// Primal–dual interior point for the dense convex QP of qp_solver.hpp.
//
// Internal form. Every finite side of a box bound or general row is a one-sided inequality
// with its own slack s ≥ 0 and multiplier λ ≥ 0:
//
//   z − lb − s_lb = 0,   ub − z − s_ub = 0,   Gz − lg − s_lg = 0,   ug − Gz − s_ug = 0,
//
// and the equality block E z = e holds the user's A z = b plus every row with lg == ug and
// every variable with lb == ub (such a pair of inequalities has no strict interior, which
// would stall the interior point). With w_b = λ_ub − λ_lb, w_g = λ_ug − λ_lg the KKT system is
//
//   r_d = H z + f + w_b + Gᵀ w_g + Eᵀ y = 0,   primal residuals = 0,   s ∘ λ = σ μ e.      (1)
//
// Eliminating Δs and Δλ from the Newton step of (1) leaves the reduced system
//
//   [ H + D_b + Gᵀ D_g G   Eᵀ ] [Δz]   [ −r_d − q_b − Gᵀ q_g ]
//   [        E             0  ] [Δy] = [        −r_e          ]                             (2)
//
// with D = Λ S⁻¹ summed over the two sides of a bound or row and q = (r_c + λ ∘ r_p)/s
// (lower side minus upper side). The n×n block M = H + D_b + Gᵀ D_g G (+δI) is factored by
// LLT; equality rows go through the Schur complement E M⁻¹ Eᵀ (+δI), also by LLT. Rows far
// from active are left out of the rank update when their contribution is below δ. When the
// regularization had to be raised, or with equality rows, iterative refinement against the
// unregularized operator removes its effect on the step.
//
// Mehrotra predictor–corrector: an affine step (σ = 0) gives μ_aff and σ = (μ_aff/μ)³, the
// combined step adds the second-order term Δs_aff ∘ Δλ_aff; both reuse one factorization.
//
// Infeasibility. The iterates of an infeasible-start interior point diverge when the problem
// has no solution: the multipliers along a Farkas ray when it is primal infeasible, the primal
// iterate along a recession direction when it is unbounded. Each iteration the current
// multipliers and the last multiplier step are tested as a Farkas certificate
//   ‖Kᵀw‖∞ ≤ ε‖w‖∞,  Σ (u_i w_i⁺ − l_i w_i⁻) < −ε‖w‖∞,
// (K stacks I, G and E; w stacks w_b, w_g, y), and the current primal iterate and the last
// primal step as a certificate of unboundedness
//   ‖Hd‖∞ ≤ ε‖d‖∞,  fᵀd < −ε‖d‖∞,  K d in the recession cone of the constraints (within ε‖d‖∞).
// The statuses are reported only when these inequalities hold, so the iterates merely propose
// the certificate and the test decides. Diverging multipliers often break the factorization
// down before ‖Kᵀw‖/‖w‖ reaches ε; on such a breakdown (or at the iteration limit) the Farkas
// test is repeated with tolerance √ε, now also demanding Σ(u w⁺ − l w⁻) < −‖Kᵀw‖∞·R, which
// proves that no feasible point has ‖z‖₁ ≤ R (R = 10 max(1, ‖z_k‖₁)).
//
// Warm start: the previous z, y and multipliers, with slacks and multipliers lifted to at
// least 1e-6. On the gen_mpc_qps.py sequence this measured best among 1e-1…1e-10 (mean 5.4
// iterations against 12.9 cold); a warm start that has not converged within
// warm_start_max_iterations restarts cold.
#include "qp/qp_solver.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "core/simd_clones.hpp"
#include "qp/dual_active_set.hpp"

namespace ridgeline::qp {

namespace {

// Sides at or beyond this magnitude are absent (the convention of qpOASES and OSQP's 1e30).
constexpr double kInfiniteBound = 1e20;
// Fraction of the step to the boundary of s, λ ≥ 0 that is taken (keeps iterates interior).
constexpr double kStepFraction = 0.99;
// Iterative-refinement passes on the reduced system (each costs about two products with G).
constexpr int kMaxRefinementPasses = 8;
// Active-set guesses tried by polish(): the first and its corrections.
constexpr int kMaxPolishAttempts = 10;
// Smallest slack and multiplier of a warm start (see warm_start()).
constexpr double kWarmStartShift = 1e-6;

bool finite_side(double v) { return std::abs(v) < kInfiniteBound; }

// No entry infinite or NaN (entries_finite, in the AVX2 clone where the CPU has it).
RIDGELINE_SIMD_CLONES bool finite_entries(const double* x, Eigen::Index n) {
  return entries_finite(x, n);
}

// Every entry of the rows × cols block at x (column-major, leading dimension ld) is finite: the
// columns one after the other in one call, where a call a column cost more than its few rows.
RIDGELINE_SIMD_CLONES bool finite_block(const double* x, Eigen::Index ld, Eigen::Index rows,
                                        Eigen::Index cols) {
  bool finite = true;
  for (Eigen::Index c = 0; c < cols; ++c) finite &= entries_finite(x + c * ld, rows);
  return finite;
}

// H is finite and symmetric to a relative 1e-10 (the round-off of an assembled H; the solver
// reads one triangle): |H(i,j) − H(j,i)| ≤ 1e-10·max(1, max |H|) for every pair. One pass over
// H in 4×4 tiles — a tile on or below the diagonal against the transpose of its mirror, both
// read by columns (contiguous) — gathers the three things the test needs: a sum of every entry
// times 0 (0 when all are finite, NaN otherwise), the largest |entry| and the largest
// |difference| of a pair, so the scale need not be known before the comparison. An
// overflowing difference (±∞) is larger than any tolerance.
RIDGELINE_SIMD_CLONES bool finite_and_symmetric(const double* h, Eigen::Index n) {
  const Eigen::Index full = n / 4 * 4;
  const Vec4 zero = {};
  Vec4 finite = {}, largest = {}, asymmetry = {};
  const auto gather = [&](Vec4 l, Vec4 u) __attribute__((always_inline)) {
    finite += l * zero + u * zero;
    Vec4 d = l - u;
    make_magnitude(l);
    make_magnitude(u);
    make_magnitude(d);
    largest = l > largest ? l : largest;
    largest = u > largest ? u : largest;
    asymmetry = d > asymmetry ? d : asymmetry;
  };
  for (Eigen::Index jb = 0; jb < full; jb += 4) {
    for (Eigen::Index ib = jb; ib < full; ib += 4) {
      // l_c = H(ib.., jb + c) and u_c = H(jb.., ib + c), named (an array would go through the
      // stack).
      Vec4 l0, l1, l2, l3, u0, u1, u2, u3;
      std::memcpy(&l0, h + jb * n + ib, sizeof l0);
      std::memcpy(&l1, h + (jb + 1) * n + ib, sizeof l1);
      std::memcpy(&l2, h + (jb + 2) * n + ib, sizeof l2);
      std::memcpy(&l3, h + (jb + 3) * n + ib, sizeof l3);
      std::memcpy(&u0, h + ib * n + jb, sizeof u0);
      std::memcpy(&u1, h + (ib + 1) * n + jb, sizeof u1);
      std::memcpy(&u2, h + (ib + 2) * n + jb, sizeof u2);
      std::memcpy(&u3, h + (ib + 3) * n + jb, sizeof u3);
      transpose4(u0, u1, u2, u3);  // now u_c = H(jb + c, ib..), the mirror of l_c
      gather(l0, u0);
      gather(l1, u1);
      gather(l2, u2);
      gather(l3, u3);
    }
  }
  double sum = (finite[0] + finite[1]) + (finite[2] + finite[3]);
  double scale = std::max(std::max(largest[0], largest[1]), std::max(largest[2], largest[3]));
  double worst =
      std::max(std::max(asymmetry[0], asymmetry[1]), std::max(asymmetry[2], asymmetry[3]));
  for (Eigen::Index i = full; i < n; ++i) {  // the rows and columns past the last whole tile
    for (Eigen::Index j = 0; j <= i; ++j) {
      const double below = h[j * n + i], above = h[i * n + j];
      sum += below * 0.0 + above * 0.0;
      scale = std::max(scale, std::max(std::abs(below), std::abs(above)));
      worst = std::max(worst, std::abs(below - above));
    }
  }
  return sum == 0.0 && !(worst > 1e-10 * std::max(1.0, scale));
}

// Prefetches x's storage into the cache, all its lines at once.
template <typename Derived>
void fetch_into_cache(const Eigen::PlainObjectBase<Derived>& x) {
  const std::size_t bytes = static_cast<std::size_t>(x.size()) * sizeof(typename Derived::Scalar);
  LinePrefetch{reinterpret_cast<const char*>(x.data()), 0, bytes}.ahead(bytes);
}

template <typename Derived>
bool all_finite(const Eigen::PlainObjectBase<Derived>& x) {
  return finite_entries(x.data(), x.size());
}

// Every pair of sides is usable: neither is NaN, a lower side is below +∞ (kInfiniteBound) and
// an upper one above −∞, and lo ≤ hi. Four pairs a test.
RIDGELINE_SIMD_CLONES bool valid_sides(const double* lo, const double* hi, Eigen::Index n) {
  const Vec4 big = {kInfiniteBound, kInfiniteBound, kInfiniteBound, kInfiniteBound};
  Mask4 bad = {};
  Eigen::Index i = 0;
  for (; i + 4 <= n; i += 4) {
    Vec4 l, h;
    std::memcpy(&l, lo + i, sizeof l);
    std::memcpy(&h, hi + i, sizeof h);
    bad |= (l != l) | (h != h) | (l >= big) | (h <= -big) | (l > h);
  }
  if ((bad[0] | bad[1] | bad[2] | bad[3]) != 0) return false;
  for (; i < n; ++i) {
    if (std::isnan(lo[i]) || std::isnan(hi[i])) return false;
    if (lo[i] >= kInfiniteBound || hi[i] <= -kInfiniteBound) return false;
    if (lo[i] > hi[i]) return false;
  }
  return true;
}

}  // namespace

std::string_view to_string(QpStatus status) {
  switch (status) {
    case QpStatus::kSolved:
      return "solved";
    case QpStatus::kIterationLimit:
      return "iteration limit";
    case QpStatus::kPrimalInfeasible:
      return "primal infeasible";
    case QpStatus::kDualInfeasible:
      return "dual infeasible (unbounded)";
    case QpStatus::kNumericalError:
      return "numerical error";
    case QpStatus::kInvalidInput:
      return "invalid input";
  }
  return "unknown";
}

std::string_view to_string(QpMethod method) {
  switch (method) {
    case QpMethod::kInteriorPoint:
      return "interior point";
    case QpMethod::kActiveSet:
      return "active set";
  }
  return "unknown";
}


namespace {

using Vec = Eigen::VectorXd;
using Arr = Eigen::ArrayXd;
using Mat = Eigen::MatrixXd;

// NaN is never allowed in bounds; a lower side of +∞ or an upper side of −∞ is meaningless.
bool valid_sides(const Vec& lo, const Vec& hi) {
  return valid_sides(lo.data(), hi.data(), lo.size());
}

// check_rows false: G's entries are left to the caller (the active set checks them through its
// product G·z; see QpSolver::solve).
bool valid_input(const QpProblem& q, bool check_rows) {
  const Eigen::Index n = q.H.rows();
  if (n <= 0 || q.H.cols() != n || q.f.size() != n) return false;
  if ((q.lb.size() != 0 && q.lb.size() != n) || (q.ub.size() != 0 && q.ub.size() != n)) {
    return false;
  }
  const Eigen::Index m = q.G.rows();
  if (m > 0 && q.G.cols() != n) return false;
  if (q.lg.size() != m || q.ug.size() != m) return false;
  const Eigen::Index p = q.A.rows();
  if (p > 0 && q.A.cols() != n) return false;
  if (q.b.size() != p) return false;
  if (!finite_and_symmetric(q.H.data(), n) || !all_finite(q.f) ||
      (check_rows && !all_finite(q.G)) || !all_finite(q.A) || !all_finite(q.b)) {
    return false;
  }
  if (q.lb.size() != 0 && q.ub.size() != 0) {
    if (!valid_sides(q.lb, q.ub)) return false;
  } else {
    for (Eigen::Index i = 0; i < n; ++i) {
      const double lo = q.lb.size() != 0 ? q.lb[i] : -kInfinity;
      const double hi = q.ub.size() != 0 ? q.ub[i] : kInfinity;
      if (!valid_sides(&lo, &hi, 1)) return false;
    }
  }
  return valid_sides(q.lg, q.ug);
}

// After the active set's kSolved: every entry of G is finite, read from the product G·z the
// solve ended with for the rows with a finite side (a non-finite entry makes its row's product
// with a finite z non-finite, ∞·0 included) and from G itself for the free rows after them,
// which the product skips. False also when the product overflowed on finite rows: the caller
// then checks G in full.
bool rows_finite(const QpProblem& q, const DualActiveSet& active_set) {
  const Eigen::Index live = active_set.live_rows(), m = q.G.rows();
  if (!all_finite(active_set.z()) || !finite_entries(active_set.row_products().data(), live)) {
    return false;
  }
  return live == m || finite_block(q.G.data() + live, q.G.outerStride(), m - live, q.G.cols());
}

// Two sides this close form an equality: as two inequalities they would leave no interior.
bool is_equality(double lo, double hi) {
  return finite_side(lo) && finite_side(hi) &&
         hi - lo <= 1e-12 * std::max(1.0, std::max(std::abs(lo), std::abs(hi)));
}

template <typename Derived>
double inf_norm(const Eigen::DenseBase<Derived>& v) {
  return v.size() == 0 ? 0.0 : v.derived().array().abs().maxCoeff();
}

// Largest α ≤ 1 with x + α dx ≥ 0 where mask is set.
double max_ratio(const Arr& x, const Arr& dx, const Arr& mask, double alpha) {
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    if (mask[i] != 0.0 && dx[i] < 0.0) alpha = std::min(alpha, -x[i] / dx[i]);
  }
  return alpha;
}

}  // namespace

struct QpSolver::Workspace {
  // Sizes of the user's problem and of the internal equality block E.
  int n = -1, m = -1, p = -1, ne = 0;
  Eigen::ArrayXi eq_row_of_g;    // m: index of the row in E, or −1
  Eigen::ArrayXi eq_row_of_var;  // n: index of the row in E, or −1

  // Problem in internal form; absent sides have mask 0, slack 1 and multiplier 0.
  const QpProblem* q = nullptr;
  Arr lb, ub, lg, ug, has_lb, has_ub, has_lg, has_ug;
  Mat E;
  Vec e;
  int num_inequalities = 0;

  // Iterate and the previous solution for warm starts.
  Vec z, y, z_prev, y_prev;
  Arr s_lb, s_ub, s_lg, s_ug, l_lb, l_ub, l_lg, l_ug;
  Arr p_lb, p_ub, p_lg, p_ug;  // previous multipliers
  bool have_previous = false;

  // Residuals, directions and temporaries.
  Vec Gz, Hz, Gtw, Ety, r_d, r_e, rhs_z, rhs_y, dz, dy, Gdz, tmp_n, tmp_m, res_z, res_y, cz, cy,
      cand_z, cand_gz, cand_hz, cand_ez;
  Arr r_lb, r_ub, r_lg, r_ug, rc_lb, rc_ub, rc_lg, rc_ug;
  Arr ds_lb, ds_ub, ds_lg, ds_ug, dl_lb, dl_ub, dl_lg, dl_ug;
  Arr d_b, d_g, q_b, q_g, g_row_norm2, cw_b, cw_g;
  Mat Gt, M, Wt, Y, S;
  Eigen::LLT<Mat> llt, llt_s;
  double reg_primal = 0.0, reg_dual = 0.0;
  bool refine = false;  // whether the regularization is large enough to need refinement

  // Polishing (see polish()): active rows C (k of them, first rows of p_C), their sources and
  // the equality-constrained KKT system on them.
  Eigen::ArrayXi p_fix;  // n: 0 free, −1 at lower bound, +1 at upper, 2 fixed by E
  Eigen::ArrayXi p_src;  // m + ne: G row j ≥ 0, or −(E row + 1)
  Eigen::ArrayXi p_side;  // m + ne: −1 lower side, +1 upper side, 0 equality
  Arr p_val;             // n: value of fixed variables
  // Per side: 0 guessed from λ > s, −1 released (wrong-signed multiplier), +1 forced (violated).
  Eigen::ArrayXi p_mode_lb, p_mode_ub, p_mode_lg, p_mode_ug;
  Mat p_C, p_Y, p_S, p_M;
  Eigen::LLT<Mat> p_llt;
  Vec p_d, p_y, p_ry, p_res_y, p_cy, p_z, p_rz, p_res_z, p_cz, p_hz, p_gz, p_ez, p_grad;

  // QpMethod::kActiveSet's solver and working set.
  DualActiveSet active_set;

  bool setup(const QpProblem& problem);
  void cold_start();
  void warm_start();
  void residuals();
  double mu() const;
  bool factor();
  void apply_reduced(const Vec& xz, const Vec& xy, Vec& out_z, Vec& out_y);
  void solve_reduced(const Vec& rz, const Vec& ry, Vec& out_z, Vec& out_y);
  void direction(const Arr& c_lb, const Arr& c_ub, const Arr& c_lg, const Arr& c_ug);
  double step_to_boundary() const;
  bool primal_infeasible(const Arr& w_b, const Arr& w_g, const Vec& w_y, double eps,
                         double radius);
  QpStatus breakdown(QpStatus status, double eps, bool have_step);
  bool dual_infeasible(const Vec& d, double eps);
  QpStatus iterate(const QpSettings& settings, int max_iterations, int& iterations);
  void fill_result(QpResult& result);
  bool polish(const QpSettings& settings);
  int polish_once(const QpSettings& settings);
  void polish_apply(int k, const Vec& xz, const Vec& xy, Vec& out_z, Vec& out_y);
  void polish_solve(int k, const Vec& rz, const Vec& ry, Vec& out_z, Vec& out_y);
};

void QpSolver::WorkspaceDeleter::operator()(Workspace* w) const { delete w; }

QpSolver::QpSolver(QpSettings settings) : settings_(settings), workspace_(new Workspace) {}

void QpSolver::reset() {
  workspace_->have_previous = false;
  workspace_->active_set.forget();
}

void QpSolver::renumber_rows(std::span<const int> new_row_of_old) {
  workspace_->active_set.renumber_rows(new_row_of_old.data(),
                                       static_cast<int>(new_row_of_old.size()));
}

bool QpSolver::Workspace::setup(const QpProblem& problem) {
  q = &problem;
  const int n_new = problem.num_variables();
  const int m_new = static_cast<int>(problem.G.rows());
  const int p_new = static_cast<int>(problem.A.rows());
  bool resized = false;
  if (n_new != n || m_new != m || p_new != p) {
    n = n_new;
    m = m_new;
    p = p_new;
    for (Arr* a : {&lb, &ub, &has_lb, &has_ub, &s_lb, &s_ub, &l_lb, &l_ub, &p_lb, &p_ub, &r_lb,
                   &r_ub, &rc_lb, &rc_ub, &ds_lb, &ds_ub, &dl_lb, &dl_ub, &d_b, &q_b, &cw_b}) {
      a->setZero(n);
    }
    for (Arr* a : {&lg, &ug, &has_lg, &has_ug, &s_lg, &s_ug, &l_lg, &l_ug, &p_lg, &p_ug, &r_lg,
                   &r_ug, &rc_lg, &rc_ug, &ds_lg, &ds_ug, &dl_lg, &dl_ug, &d_g, &q_g, &g_row_norm2, &cw_g}) {
      a->setZero(m);
    }
    for (Vec* v : {&z, &z_prev, &Hz, &Gtw, &Ety, &r_d, &rhs_z, &dz, &tmp_n, &res_z, &cz, &cand_z,
                   &cand_hz}) {
      v->setZero(n);
    }
    for (Vec* v : {&Gz, &Gdz, &tmp_m, &cand_gz, &p_gz}) v->setZero(m);
    for (Vec* v : {&p_z, &p_rz, &p_res_z, &p_cz, &p_hz, &p_grad}) v->setZero(n);
    p_fix.setZero(n);
    p_val.setZero(n);
    for (Eigen::ArrayXi* a : {&p_mode_lb, &p_mode_ub}) a->setZero(n);
    for (Eigen::ArrayXi* a : {&p_mode_lg, &p_mode_ug}) a->setZero(m);
    p_M.setZero(n, n);
    eq_row_of_g.setConstant(m, -2);
    eq_row_of_var.setConstant(n, -2);
    M.setZero(n, n);
    Gt.setZero(n, m);
    Wt.setZero(n, m);
    resized = true;
  }

  // Equality pattern: the user's rows, then rows with lg == ug, then fixed variables.
  bool pattern_changed = resized;
  int count = p;
  for (int j = 0; j < m; ++j) {
    const int row = is_equality(problem.lg[j], problem.ug[j]) ? count++ : -1;
    pattern_changed |= row != eq_row_of_g[j];
    eq_row_of_g[j] = row;
  }
  for (int i = 0; i < n; ++i) {
    const bool fixed = problem.lb.size() != 0 && problem.ub.size() != 0 &&
                       is_equality(problem.lb[i], problem.ub[i]);
    const int row = fixed ? count++ : -1;
    pattern_changed |= row != eq_row_of_var[i];
    eq_row_of_var[i] = row;
  }
  if (pattern_changed) {
    ne = count;
    E.setZero(ne, n);
    e.setZero(ne);
    for (Vec* v : {&y, &y_prev, &r_e, &rhs_y, &dy, &res_y, &cy, &cand_ez}) v->setZero(ne);
    Y.setZero(n, ne);
    S.setZero(ne, ne);
    const int rows = m + ne;
    for (Vec* v : {&p_d, &p_y, &p_ry, &p_res_y, &p_cy}) v->setZero(rows);
    p_ez.setZero(ne);
    p_src.setZero(rows);
    p_side.setZero(rows);
    p_C.setZero(rows, n);
    p_Y.setZero(n, rows);
    p_S.setZero(rows, rows);
    have_previous = false;
  }

  // Data in internal form.
  num_inequalities = 0;
  for (int i = 0; i < n; ++i) {
    const double lo = problem.lb.size() != 0 ? problem.lb[i] : -kInfinity;
    const double hi = problem.ub.size() != 0 ? problem.ub[i] : kInfinity;
    const bool fixed = eq_row_of_var[i] >= 0;
    has_lb[i] = !fixed && finite_side(lo) ? 1.0 : 0.0;
    has_ub[i] = !fixed && finite_side(hi) ? 1.0 : 0.0;
    lb[i] = has_lb[i] != 0.0 ? lo : 0.0;
    ub[i] = has_ub[i] != 0.0 ? hi : 0.0;
    if (fixed) {
      E.row(eq_row_of_var[i]).setZero();
      E(eq_row_of_var[i], i) = 1.0;
      e[eq_row_of_var[i]] = 0.5 * (lo + hi);
    }
  }
  for (int j = 0; j < m; ++j) {
    const bool eq = eq_row_of_g[j] >= 0;
    has_lg[j] = !eq && finite_side(problem.lg[j]) ? 1.0 : 0.0;
    has_ug[j] = !eq && finite_side(problem.ug[j]) ? 1.0 : 0.0;
    lg[j] = has_lg[j] != 0.0 ? problem.lg[j] : 0.0;
    ug[j] = has_ug[j] != 0.0 ? problem.ug[j] : 0.0;
    if (eq) {
      E.row(eq_row_of_g[j]) = problem.G.row(j);
      e[eq_row_of_g[j]] = 0.5 * (problem.lg[j] + problem.ug[j]);
    }
  }
  if (p > 0) {
    E.topRows(p) = problem.A;
    e.head(p) = problem.b;
  }
  if (m > 0) {
    Gt = problem.G.transpose();
    g_row_norm2 = Gt.colwise().squaredNorm().transpose().array();
  }
  num_inequalities = static_cast<int>(has_lb.sum() + has_ub.sum() + has_lg.sum() + has_ug.sum());
  return true;
}

void QpSolver::Workspace::residuals() {
  const QpProblem& pr = *q;
  Hz.noalias() = pr.H * z;
  if (m > 0) {
    Gz.noalias() = pr.G * z;
    cw_g = l_ug - l_lg;
    Gtw.noalias() = Gt * cw_g.matrix();
  } else {
    Gtw.setZero();
  }
  if (ne > 0) {
    Ety.noalias() = E.transpose() * y;
    r_e.noalias() = E * z;
    r_e -= e;
  } else {
    Ety.setZero();
  }
  r_d = Hz + pr.f + Gtw + Ety;
  r_d.array() += l_ub - l_lb;
  r_lb = has_lb * (z.array() - lb - s_lb);
  r_ub = has_ub * (ub - z.array() - s_ub);
  r_lg = has_lg * (Gz.array() - lg - s_lg);
  r_ug = has_ug * (ug - Gz.array() - s_ug);
}

double QpSolver::Workspace::mu() const {
  if (num_inequalities == 0) return 0.0;
  return ((s_lb * l_lb).sum() + (s_ub * l_ub).sum() + (s_lg * l_lg).sum() +
          (s_ug * l_ug).sum()) /
         num_inequalities;
}

// Forms and factors the reduced matrix (2) at the current D = Λ S⁻¹. The primal
// regularization keeps it definite when H is only semidefinite on free directions; it grows
// by 100× when the factorization fails.
bool QpSolver::Workspace::factor() {
  const QpProblem& pr = *q;
  d_b = has_lb * l_lb / s_lb + has_ub * l_ub / s_ub;
  d_g = has_lg * l_lg / s_lg + has_ug * l_ug / s_ug;
  M.triangularView<Eigen::Lower>() = pr.H;
  M.diagonal() += d_b.matrix();
  // Relative to H, not to D: D grows without bound on active constraints, and regularization
  // of that size would swamp the reduced Hessian on the active constraints' null space.
  const double scale = std::max(1.0, pr.H.diagonal().cwiseAbs().maxCoeff());
  reg_primal = 1e-12 * scale;
  if (m > 0) {
    // Rows far from active (D_j ‖g_j‖² below the regularization) change M by less than the
    // regularization does; leaving them out of the rank update makes late iterations cheaper.
    int kept = 0;
    const double drop_below = reg_primal;
    for (int j = 0; j < m; ++j) {
      if (d_g[j] * g_row_norm2[j] > drop_below) {
        Wt.col(kept++) = std::sqrt(d_g[j]) * Gt.col(j);
      }
    }
    if (kept > 0) M.selfadjointView<Eigen::Lower>().rankUpdate(Wt.leftCols(kept));
  }
  reg_dual = ne > 0 ? 1e-10 : 0.0;
  for (int attempt = 0; attempt < 6; ++attempt, reg_primal *= 100.0) {
    refine = attempt > 0 || ne > 0;
    M.diagonal().array() += reg_primal;
    llt.compute(M);
    M.diagonal().array() -= reg_primal;
    if (llt.info() != Eigen::Success) continue;
    if (ne == 0) return true;
    // Equality rows through the Schur complement S = E M⁻¹ Eᵀ + δI, with Y = L⁻¹Eᵀ so that
    // S = YᵀY + δI. δ keeps S definite when E is rank deficient (duplicated equality rows);
    // refinement against the exact operator removes its effect on consistent systems.
    Y = E.transpose();
    llt.matrixL().solveInPlace(Y);
    S.setZero();
    S.selfadjointView<Eigen::Lower>().rankUpdate(Y.transpose());
    reg_dual = 1e-12 * std::max(1.0, S.diagonal().maxCoeff()) * std::pow(100.0, attempt);
    S.diagonal().array() += reg_dual;
    llt_s.compute(S);
    if (llt_s.info() == Eigen::Success) return true;
  }
  return false;
}

// out = [H + D_b + Gᵀ D_g G, Eᵀ; E, 0] x without regularization.
void QpSolver::Workspace::apply_reduced(const Vec& xz, const Vec& xy, Vec& out_z, Vec& out_y) {
  const QpProblem& pr = *q;
  out_z.noalias() = pr.H * xz;
  out_z.array() += d_b * xz.array();
  if (m > 0) {
    tmp_m.noalias() = pr.G * xz;
    tmp_m.array() *= d_g;
    out_z.noalias() += Gt * tmp_m;
  }
  if (ne > 0) {
    out_z.noalias() += E.transpose() * xy;
    out_y.noalias() = E * xz;
  }
}

// Solves (2) with the factorization, then refines against the unregularized operator until
// the residual stops improving (at most three passes): the regularization then costs nothing
// in the accuracy of the step.
void QpSolver::Workspace::solve_reduced(const Vec& rz, const Vec& ry, Vec& out_z, Vec& out_y) {
  auto raw_solve = [&](const Vec& bz, const Vec& by, Vec& xz, Vec& xy) {
    xz = llt.solve(bz);
    if (ne > 0) {
      // dy = S⁻¹(E M⁻¹ b_z − b_y), dz = M⁻¹(b_z − Eᵀ dy).
      xy.noalias() = E * xz;
      xy -= by;
      llt_s.solveInPlace(xy);
      tmp_n.noalias() = E.transpose() * xy;
      llt.solveInPlace(tmp_n);
      xz -= tmp_n;
    }
  };
  raw_solve(rz, ry, out_z, out_y);
  if (!refine) return;
  const double rhs_norm = std::max(inf_norm(rz), ne > 0 ? inf_norm(ry) : 0.0);
  double previous = kInfinity;
  for (int pass = 0; pass < kMaxRefinementPasses; ++pass) {
    apply_reduced(out_z, out_y, res_z, res_y);
    res_z = rz - res_z;
    if (ne > 0) res_y = ry - res_y;
    const double r = std::max(inf_norm(res_z), ne > 0 ? inf_norm(res_y) : 0.0);
    if (r <= 1e-14 * rhs_norm || r >= 0.5 * previous) break;
    previous = r;
    raw_solve(res_z, res_y, cz, cy);
    out_z += cz;
    if (ne > 0) out_y += cy;
  }
}

// Newton direction of (1) for the complementarity residual c = s∘λ − target.
void QpSolver::Workspace::direction(const Arr& c_lb, const Arr& c_ub, const Arr& c_lg,
                                    const Arr& c_ug) {
  q_b = has_lb * (c_lb + l_lb * r_lb) / s_lb - has_ub * (c_ub + l_ub * r_ub) / s_ub;
  rhs_z = -r_d - q_b.matrix();
  if (m > 0) {
    q_g = has_lg * (c_lg + l_lg * r_lg) / s_lg - has_ug * (c_ug + l_ug * r_ug) / s_ug;
    rhs_z.noalias() -= Gt * q_g.matrix();
  }
  if (ne > 0) rhs_y = -r_e;
  solve_reduced(rhs_z, rhs_y, dz, dy);
  ds_lb = has_lb * (dz.array() + r_lb);
  ds_ub = has_ub * (r_ub - dz.array());
  dl_lb = has_lb * (-c_lb - l_lb * ds_lb) / s_lb;
  dl_ub = has_ub * (-c_ub - l_ub * ds_ub) / s_ub;
  if (m > 0) {
    Gdz.noalias() = q->G * dz;
    ds_lg = has_lg * (Gdz.array() + r_lg);
    ds_ug = has_ug * (r_ug - Gdz.array());
    dl_lg = has_lg * (-c_lg - l_lg * ds_lg) / s_lg;
    dl_ug = has_ug * (-c_ug - l_ug * ds_ug) / s_ug;
  }
}

double QpSolver::Workspace::step_to_boundary() const {
  double a = 1.0;
  a = max_ratio(s_lb, ds_lb, has_lb, a);
  a = max_ratio(s_ub, ds_ub, has_ub, a);
  a = max_ratio(s_lg, ds_lg, has_lg, a);
  a = max_ratio(s_ug, ds_ug, has_ug, a);
  a = max_ratio(l_lb, dl_lb, has_lb, a);
  a = max_ratio(l_ub, dl_ub, has_ub, a);
  a = max_ratio(l_lg, dl_lg, has_lg, a);
  a = max_ratio(l_ug, dl_ug, has_ug, a);
  return a;
}

// Farkas test for w = (w_b, w_g, w_y), signed like the reported multipliers (+ upper, − lower).
bool QpSolver::Workspace::primal_infeasible(const Arr& w_b, const Arr& w_g, const Vec& w_y,
                                            double eps, double radius) {
  const double norm_w = std::max({inf_norm(w_b), inf_norm(w_g), inf_norm(w_y)});
  if (!(norm_w > 0.0) || !std::isfinite(norm_w)) return false;
  // Support function Σ u_i w_i⁺ − l_i w_i⁻; +∞ when w pushes against an absent side.
  double support = 0.0;
  for (int i = 0; i < n; ++i) {
    if (w_b[i] > 0.0) {
      if (has_ub[i] == 0.0) return false;
      support += ub[i] * w_b[i];
    } else if (w_b[i] < 0.0) {
      if (has_lb[i] == 0.0) return false;
      support += lb[i] * w_b[i];
    }
  }
  for (int j = 0; j < m; ++j) {
    if (w_g[j] > 0.0) {
      if (has_ug[j] == 0.0) return false;
      support += ug[j] * w_g[j];
    } else if (w_g[j] < 0.0) {
      if (has_lg[j] == 0.0) return false;
      support += lg[j] * w_g[j];
    }
  }
  if (ne > 0) support += e.dot(w_y);
  if (!(support < -eps * norm_w)) return false;
  cand_z = w_b.matrix();
  if (m > 0) cand_z.noalias() += Gt * w_g.matrix();
  if (ne > 0) cand_z.noalias() += E.transpose() * w_y;
  // Any feasible z has support ≥ wᵀKz ≥ −‖Kᵀw‖∞‖z‖₁, so no feasible point lies in the
  // 1-norm ball of this radius.
  const double ktw = inf_norm(cand_z);
  return ktw <= eps * norm_w && support < -ktw * radius;
}

// The iteration cannot continue (factorization breakdown, stalled steps, iteration limit).
// Diverging multipliers are the usual cause on infeasible problems and they make the
// factorization break down before ‖Kᵀw‖/‖w‖ reaches the infeasibility tolerance, so the
// certificate is tested once more with tolerance √ε, now demanding in addition that no
// feasible point lies within 10× the current iterate's 1-norm (see primal_infeasible()).
QpStatus QpSolver::Workspace::breakdown(QpStatus status, double eps, bool have_step) {
  const double loose = std::sqrt(eps);
  const double radius = 10.0 * std::max(1.0, z.lpNorm<1>());
  cw_b = l_ub - l_lb;
  cw_g = l_ug - l_lg;
  if (primal_infeasible(cw_b, cw_g, y, loose, radius)) return QpStatus::kPrimalInfeasible;
  if (have_step) {
    cw_b = dl_ub - dl_lb;
    cw_g = dl_ug - dl_lg;
    if (primal_infeasible(cw_b, cw_g, dy, loose, radius)) return QpStatus::kPrimalInfeasible;
  }
  return status;
}

// Recession-direction test for d: Hd = 0, fᵀd < 0, Kd within the constraints' recession cone.
bool QpSolver::Workspace::dual_infeasible(const Vec& d, double eps) {
  const double norm_d = inf_norm(d);
  if (!(norm_d > 0.0) || !std::isfinite(norm_d)) return false;
  const double tol = eps * norm_d;
  if (!(q->f.dot(d) < -tol)) return false;
  for (int i = 0; i < n; ++i) {
    if ((has_lb[i] != 0.0 && d[i] < -tol) || (has_ub[i] != 0.0 && d[i] > tol)) return false;
  }
  if (m > 0) {
    cand_gz.noalias() = q->G * d;
    for (int j = 0; j < m; ++j) {
      if ((has_lg[j] != 0.0 && cand_gz[j] < -tol) || (has_ug[j] != 0.0 && cand_gz[j] > tol)) {
        return false;
      }
    }
  }
  if (ne > 0) {
    cand_ez.noalias() = E * d;
    if (inf_norm(cand_ez) > tol) return false;
  }
  cand_hz.noalias() = q->H * d;
  return inf_norm(cand_hz) <= tol;
}

// Cold start in the manner of Mehrotra's LP heuristic: z minimizes the objective plus
// ½Σ (distance to each finite side)², i.e. (2) with S = Λ = I, which pulls z toward the middle
// of two-sided rows; slacks below 1 are lifted to 1.
void QpSolver::Workspace::cold_start() {
  const QpProblem& pr = *q;
  s_lb = Arr::Ones(n);
  s_ub = Arr::Ones(n);
  s_lg = Arr::Ones(m);
  s_ug = Arr::Ones(m);
  l_lb = has_lb;
  l_ub = has_ub;
  l_lg = has_lg;
  l_ug = has_ug;
  z.setZero();
  if (ne > 0) y.setZero();
  if (factor()) {
    rhs_z = -pr.f;
    rhs_z.array() += has_lb * lb + has_ub * ub;
    if (m > 0) {
      q_g = has_lg * lg + has_ug * ug;
      rhs_z.noalias() += Gt * q_g.matrix();
    }
    if (ne > 0) rhs_y = e;
    solve_reduced(rhs_z, rhs_y, z, y);
    if (!z.allFinite()) z.setZero();
    if (ne > 0 && !y.allFinite()) y.setZero();
  }
  if (m > 0) Gz.noalias() = pr.G * z;
  const double floor = 1.0;
  s_lb = has_lb * (z.array() - lb).max(floor) + (1.0 - has_lb);
  s_ub = has_ub * (ub - z.array()).max(floor) + (1.0 - has_ub);
  s_lg = has_lg * (Gz.array() - lg).max(floor) + (1.0 - has_lg);
  s_ug = has_ug * (ug - Gz.array()).max(floor) + (1.0 - has_ug);
  // Multipliers λ = c/s put every pair on the central path s∘λ = c; c = √‖f‖∞ (at least 1)
  // gives the multipliers the objective's order of magnitude (cost scale over constraint
  // scale) without the objective scale itself, which measured best on the MPC instances.
  const double c = std::sqrt(std::max(1.0, inf_norm(pr.f)));
  l_lb = c * has_lb / s_lb;
  l_ub = c * has_ub / s_ub;
  l_lg = c * has_lg / s_lg;
  l_ug = c * has_ug / s_ug;
}

// Warm start: the previous primal–dual point, pushed back into the interior. At the previous
// optimum active slacks and inactive multipliers are ~0, which would pin the first steps to
// the boundary; lifting both to at least θ restores room to move while keeping the active
// set the previous solution identified.
void QpSolver::Workspace::warm_start() {
  const QpProblem& pr = *q;
  z = z_prev;
  if (ne > 0) y = y_prev;
  if (m > 0) Gz.noalias() = pr.G * z;
  const double theta = kWarmStartShift;
  s_lb = has_lb * (z.array() - lb).max(theta) + (1.0 - has_lb);
  s_ub = has_ub * (ub - z.array()).max(theta) + (1.0 - has_ub);
  s_lg = has_lg * (Gz.array() - lg).max(theta) + (1.0 - has_lg);
  s_ug = has_ug * (ug - Gz.array()).max(theta) + (1.0 - has_ug);
  l_lb = has_lb * p_lb.max(theta);
  l_ub = has_ub * p_ub.max(theta);
  l_lg = has_lg * p_lg.max(theta);
  l_ug = has_ug * p_ug.max(theta);
}

QpStatus QpSolver::Workspace::iterate(const QpSettings& settings, int max_iterations,
                                      int& iterations) {
  const QpProblem& pr = *q;
  const double tol = settings.tolerance;
  const double eps_inf = settings.infeasibility_tolerance;
  bool have_step = false;
  int stalled = 0;
  for (int k = 0;; ++k) {
    iterations = k;
    residuals();
    const double primal = std::max({inf_norm(r_lb), inf_norm(r_ub), inf_norm(r_lg),
                                    inf_norm(r_ug), ne > 0 ? inf_norm(r_e) : 0.0});
    const double primal_scale =
        std::max({1.0, inf_norm(z), inf_norm(Gz), ne > 0 ? inf_norm(e) : 0.0});
    const double dual = inf_norm(r_d);
    const double dual_scale = std::max({1.0, inf_norm(Hz), inf_norm(pr.f), inf_norm(Gtw),
                                        inf_norm(l_ub - l_lb), inf_norm(Ety)});
    const double mu_now = mu();
    const double gap = mu_now * num_inequalities;
    const double gap_scale = std::max({1.0, std::abs(z.dot(Hz)), std::abs(pr.f.dot(z))});
    if (!std::isfinite(primal) || !std::isfinite(dual) || !std::isfinite(gap)) {
      return QpStatus::kNumericalError;
    }
    if (primal <= tol * primal_scale && dual <= tol * dual_scale && gap <= tol * gap_scale) {
      return QpStatus::kSolved;
    }
    if (k > 0) {
      cw_b = l_ub - l_lb;
      cw_g = l_ug - l_lg;
      if (primal_infeasible(cw_b, cw_g, y, eps_inf, 1.0)) return QpStatus::kPrimalInfeasible;
      if (dual_infeasible(z, eps_inf)) return QpStatus::kDualInfeasible;
      if (have_step) {
        cw_b = dl_ub - dl_lb;
        cw_g = dl_ug - dl_lg;
        if (primal_infeasible(cw_b, cw_g, dy, eps_inf, 1.0)) return QpStatus::kPrimalInfeasible;
        if (dual_infeasible(dz, eps_inf)) return QpStatus::kDualInfeasible;
      }
    }
    if (k >= max_iterations) return breakdown(QpStatus::kIterationLimit, eps_inf, have_step);
    if (!factor()) {
      return breakdown(QpStatus::kNumericalError, eps_inf, have_step);
    }

    double alpha = 1.0;
    if (num_inequalities == 0) {
      rc_lb.setZero();
      rc_ub.setZero();
      rc_lg.setZero();
      rc_ug.setZero();
      direction(rc_lb, rc_ub, rc_lg, rc_ug);
    } else {
      // Predictor: the affine-scaling direction (σ = 0).
      rc_lb = s_lb * l_lb;
      rc_ub = s_ub * l_ub;
      rc_lg = s_lg * l_lg;
      rc_ug = s_ug * l_ug;
      direction(rc_lb, rc_ub, rc_lg, rc_ug);
      const double a_aff = step_to_boundary();
      const double mu_aff =
          (((s_lb + a_aff * ds_lb) * (l_lb + a_aff * dl_lb)).sum() +
           ((s_ub + a_aff * ds_ub) * (l_ub + a_aff * dl_ub)).sum() +
           ((s_lg + a_aff * ds_lg) * (l_lg + a_aff * dl_lg)).sum() +
           ((s_ug + a_aff * ds_ug) * (l_ug + a_aff * dl_ug)).sum()) /
          num_inequalities;
      const double ratio = mu_now > 0.0 ? std::clamp(mu_aff / mu_now, 0.0, 1.0) : 0.0;
      const double sigma = ratio * ratio * ratio;
      // Corrector: centring σμ plus the second-order term Δs_aff ∘ Δλ_aff.
      const double target = sigma * mu_now;
      rc_lb = has_lb * (s_lb * l_lb + ds_lb * dl_lb - target);
      rc_ub = has_ub * (s_ub * l_ub + ds_ub * dl_ub - target);
      rc_lg = has_lg * (s_lg * l_lg + ds_lg * dl_lg - target);
      rc_ug = has_ug * (s_ug * l_ug + ds_ug * dl_ug - target);
      direction(rc_lb, rc_ub, rc_lg, rc_ug);
      alpha = std::min(1.0, kStepFraction * step_to_boundary());
    }
    if (!dz.allFinite() || (ne > 0 && !dy.allFinite())) return QpStatus::kNumericalError;
    have_step = true;
    z += alpha * dz;
    if (ne > 0) y += alpha * dy;
    s_lb += alpha * ds_lb;
    s_ub += alpha * ds_ub;
    s_lg += alpha * ds_lg;
    s_ug += alpha * ds_ug;
    l_lb += alpha * dl_lb;
    l_ub += alpha * dl_ub;
    l_lg += alpha * dl_lg;
    l_ug += alpha * dl_ug;
    stalled = alpha < 1e-10 ? stalled + 1 : 0;
    if (stalled >= 5) {
      iterations = k + 1;
      residuals();
      return breakdown(QpStatus::kNumericalError, eps_inf, have_step);
    }
  }
}

void QpSolver::Workspace::fill_result(QpResult& r) {
  const QpProblem& pr = *q;
  r.z = z;
  r.dual_bounds = (l_ub - l_lb).matrix();
  r.dual_rows = (l_ug - l_lg).matrix();
  r.dual_eq.resize(p);
  if (p > 0) r.dual_eq = y.head(p);
  for (int j = 0; j < m; ++j) {
    if (eq_row_of_g[j] >= 0) r.dual_rows[j] = y[eq_row_of_g[j]];
  }
  for (int i = 0; i < n; ++i) {
    if (eq_row_of_var[i] >= 0) r.dual_bounds[i] = y[eq_row_of_var[i]];
  }
  r.objective = 0.5 * z.dot(Hz) + pr.f.dot(z);
  double violation = 0.0;
  for (int i = 0; i < n; ++i) {
    if (pr.lb.size() != 0 && finite_side(pr.lb[i])) violation = std::max(violation, pr.lb[i] - z[i]);
    if (pr.ub.size() != 0 && finite_side(pr.ub[i])) violation = std::max(violation, z[i] - pr.ub[i]);
  }
  for (int j = 0; j < m; ++j) {
    if (finite_side(pr.lg[j])) violation = std::max(violation, pr.lg[j] - Gz[j]);
    if (finite_side(pr.ug[j])) violation = std::max(violation, Gz[j] - pr.ug[j]);
  }
  if (p > 0) {
    for (int i = 0; i < p; ++i) violation = std::max(violation, std::abs(r_e[i]));
  }
  r.primal_residual = violation;
  r.dual_residual = inf_norm(r_d);
  r.duality_gap = mu() * num_inequalities;
}

// Polishing. The interior point leaves active slacks and multipliers at ~√μ, so z is only
// ~√μ-accurate where a constraint is degenerate. The active set is guessed from the final
// iterate (a side is active when λ > s; equality rows always are); variables at an active
// bound are fixed, and the remaining equality-constrained QP
//
//   [ M  Cᵀ ] [z]   [ −f − H z_X + ρ Cᵀd ]        M = H_FF (identity on fixed variables) + ρ CᵀC,
//   [ C  0  ] [y] = [          d          ]                                                  (3)
//
// is solved like (2): LLT of M + σI, Schur complement C M⁻¹ Cᵀ + δI, refinement against the
// exact operator. The augmented-Lagrangian term ρCᵀC does not change the solution (Cz = d) but
// makes M definite when H is only semidefinite on free directions; δ handles dependent
// (duplicated) active rows. The point is accepted by the caller's tests only (see polish()).
//
// Degenerate problems (more active rows than free variables, duplicated rows) have a whole
// face of optimal multipliers, and the multipliers the regularized solve picks from a zero
// start (nearly minimum-norm) often have wrong signs although sign-correct ones exist. So (3)
// is solved by iterative refinement started at the interior point, z and the active sides'
// multipliers: each correction is δ-regularized, which leaves the component of the start in
// the null space of the active rows untouched, so the multipliers stay near the interior
// point's, which lie inside the optimal dual face and have the right signs.
void QpSolver::Workspace::polish_apply(int k, const Vec& xz, const Vec& xy, Vec& out_z,
                                       Vec& out_y) {
  out_z.noalias() = p_M * xz;
  if (k > 0) {
    out_z.noalias() += p_C.topRows(k).transpose() * xy.head(k);
    out_y.head(k).noalias() = p_C.topRows(k) * xz;
  }
}

void QpSolver::Workspace::polish_solve(int k, const Vec& rz, const Vec& ry, Vec& out_z,
                                       Vec& out_y) {
  auto raw_solve = [&](const Vec& bz, const Vec& by, Vec& xz, Vec& xy) {
    xz = p_llt.solve(bz);
    if (k > 0) {
      xy.head(k).noalias() = p_C.topRows(k) * xz;
      xy.head(k) -= by.head(k);
      p_S.topLeftCorner(k, k).triangularView<Eigen::Lower>().solveInPlace(xy.head(k));
      p_S.topLeftCorner(k, k).triangularView<Eigen::Lower>().transpose().solveInPlace(
          xy.head(k));
      p_hz.noalias() = p_C.topRows(k).transpose() * xy.head(k);
      p_llt.solveInPlace(p_hz);
      xz -= p_hz;
    }
  };
  const double rhs_norm = std::max(inf_norm(rz), k > 0 ? inf_norm(ry.head(k)) : 0.0);
  double previous = kInfinity;
  // The first pass measures the start's residual; each further one corrects it.
  for (int pass = 0; pass <= kMaxRefinementPasses; ++pass) {
    polish_apply(k, out_z, out_y, p_res_z, p_res_y);
    p_res_z = rz - p_res_z;
    if (k > 0) p_res_y.head(k) = ry.head(k) - p_res_y.head(k);
    const double r = std::max(inf_norm(p_res_z), k > 0 ? inf_norm(p_res_y.head(k)) : 0.0);
    if (r <= 1e-15 * rhs_norm || r >= 0.5 * previous) break;
    previous = r;
    raw_solve(p_res_z, p_res_y, p_cz, p_cy);
    out_z += p_cz;
    if (k > 0) out_y.head(k) += p_cy.head(k);
  }
}

// Replaces the interior-point solution by the solution of (3) when that point is primal
// feasible, its multipliers have the right signs and its objective is not higher, each within
// the solver's relative tolerance; returns whether it did. The iterate is untouched otherwise.
// A guess whose multipliers have a wrong sign, or whose point violates a side, is corrected
// (release those sides, force the violated ones) up to kMaxPolishAttempts − 1 times before
// giving up. Releasing a degenerate side (active, zero multiplier) does not move the solution,
// and with fewer rows the multipliers are closer to unique; on the random degenerate QPs of
// the tests a guess needs at most three corrections. Each attempt costs one factorization of
// (3), and the first guess usually stands (MPC: about 93% of solves).
bool QpSolver::Workspace::polish(const QpSettings& settings) {
  p_mode_lb.setZero();
  p_mode_ub.setZero();
  p_mode_lg.setZero();
  p_mode_ug.setZero();
  for (int attempt = 0; attempt < kMaxPolishAttempts; ++attempt) {
    const int outcome = polish_once(settings);
    if (outcome >= 0) return outcome == 1;
  }
  return false;
}

int QpSolver::Workspace::polish_once(const QpSettings& settings) {
  const QpProblem& pr = *q;
  const double tol = settings.tolerance;
  // Active set and fixed variables.
  for (int i = 0; i < n; ++i) {
    p_fix[i] = 0;
    if (eq_row_of_var[i] >= 0) {
      p_fix[i] = 2;
      p_val[i] = e[eq_row_of_var[i]];
    } else {
      const bool lo = has_lb[i] != 0.0 && p_mode_lb[i] >= 0 &&
                      (l_lb[i] > s_lb[i] || p_mode_lb[i] > 0);
      const bool hi = has_ub[i] != 0.0 && p_mode_ub[i] >= 0 &&
                      (l_ub[i] > s_ub[i] || p_mode_ub[i] > 0);
      if (lo && (!hi || l_lb[i] >= l_ub[i])) {
        p_fix[i] = -1;
        p_val[i] = lb[i];
      } else if (hi) {
        p_fix[i] = 1;
        p_val[i] = ub[i];
      }
    }
  }
  int k = 0;
  for (int r = 0; r < ne; ++r) {
    bool fixes_variable = false;
    for (int i = 0; i < n && !fixes_variable; ++i) fixes_variable = eq_row_of_var[i] == r;
    if (fixes_variable) continue;
    p_C.row(k) = E.row(r);
    p_d[k] = e[r];
    p_src[k] = -(r + 1);
    p_side[k] = 0;
    ++k;
  }
  for (int j = 0; j < m; ++j) {
    if (eq_row_of_g[j] >= 0) continue;
    const bool lo = has_lg[j] != 0.0 && p_mode_lg[j] >= 0 &&
                    (l_lg[j] > s_lg[j] || p_mode_lg[j] > 0);
    const bool hi = has_ug[j] != 0.0 && p_mode_ug[j] >= 0 &&
                    (l_ug[j] > s_ug[j] || p_mode_ug[j] > 0);
    if (!lo && !hi) continue;
    const bool lower = lo && (!hi || l_lg[j] >= l_ug[j]);
    p_C.row(k) = pr.G.row(j);
    p_d[k] = lower ? lg[j] : ug[j];
    p_src[k] = j;
    p_side[k] = lower ? -1 : 1;
    ++k;
  }
  // Move the fixed variables to the right-hand side: p_z holds z_X (zero elsewhere).
  p_z.setZero();
  for (int i = 0; i < n; ++i) {
    if (p_fix[i] != 0) p_z[i] = p_val[i];
  }
  if (k > 0) {
    p_d.head(k).noalias() -= p_C.topRows(k) * p_z;
    for (int i = 0; i < n; ++i) {
      if (p_fix[i] != 0) p_C.col(i).head(k).setZero();
    }
  }
  p_hz.noalias() = pr.H * p_z;
  p_rz = -pr.f - p_hz;
  p_M = pr.H;
  const double h_scale = std::max(1.0, pr.H.diagonal().cwiseAbs().maxCoeff());
  if (k > 0) {
    const double c_scale = std::max(1.0, p_C.topRows(k).rowwise().squaredNorm().maxCoeff());
    const double rho = h_scale / c_scale;
    p_M.noalias() += rho * (p_C.topRows(k).transpose() * p_C.topRows(k));
    p_rz.noalias() += rho * (p_C.topRows(k).transpose() * p_d.head(k));
  }
  for (int i = 0; i < n; ++i) {
    if (p_fix[i] == 0) continue;
    p_M.row(i).setZero();
    p_M.col(i).setZero();
    p_M(i, i) = 1.0;
    p_rz[i] = p_val[i];
  }
  // Factor M + σI and S = C (M + σI)⁻¹ Cᵀ + δI (S's Cholesky factor kept in p_S's lower part).
  double sigma = 1e-12 * h_scale;
  bool factored = false;
  for (int attempt = 0; attempt < 4 && !factored; ++attempt, sigma *= 100.0) {
    p_M.diagonal().array() += sigma;
    p_llt.compute(p_M);
    p_M.diagonal().array() -= sigma;
    if (p_llt.info() != Eigen::Success) continue;
    if (k == 0) {
      factored = true;
      break;
    }
    p_Y.leftCols(k) = p_C.topRows(k).transpose();
    p_llt.matrixL().solveInPlace(p_Y.leftCols(k));
    p_S.topLeftCorner(k, k).setZero();
    p_S.topLeftCorner(k, k).selfadjointView<Eigen::Lower>().rankUpdate(
        p_Y.leftCols(k).transpose());
    const double delta =
        1e-12 * std::max(1.0, p_S.topLeftCorner(k, k).diagonal().maxCoeff()) *
        std::pow(100.0, attempt);
    p_S.topLeftCorner(k, k).diagonal().array() += delta;
    Eigen::Ref<Mat> s_block(p_S.topLeftCorner(k, k));
    Eigen::LLT<Eigen::Ref<Mat>> llt_s_inplace(s_block);
    factored = llt_s_inplace.info() == Eigen::Success;
  }
  if (!factored) return 0;
  p_ry.head(k) = p_d.head(k);
  // Start from the interior point: z, and the multipliers of the active sides.
  for (int i = 0; i < n; ++i) p_z[i] = p_fix[i] != 0 ? p_val[i] : z[i];
  for (int r = 0; r < k; ++r) {
    p_y[r] = p_src[r] < 0 ? y[-p_src[r] - 1] : l_ug[p_src[r]] - l_lg[p_src[r]];
  }
  polish_solve(k, p_rz, p_ry, p_z, p_y);
  if (!p_z.allFinite() || (k > 0 && !p_y.head(k).allFinite())) return 0;
  for (int i = 0; i < n; ++i) {
    if (p_fix[i] != 0) p_z[i] = p_val[i];
  }

  // Acceptance tests with the scales of the interior point's convergence test.
  p_hz.noalias() = pr.H * p_z;
  if (m > 0) p_gz.noalias() = pr.G * p_z;
  const double primal_scale =
      std::max({1.0, inf_norm(p_z), inf_norm(p_gz), ne > 0 ? inf_norm(e) : 0.0});
  const double primal_tol = tol * primal_scale;
  bool retry = false;
  for (int i = 0; i < n; ++i) {
    if (has_lb[i] != 0.0 && lb[i] - p_z[i] > primal_tol) retry = (p_mode_lb[i] = 1);
    if (has_ub[i] != 0.0 && p_z[i] - ub[i] > primal_tol) retry = (p_mode_ub[i] = 1);
  }
  for (int j = 0; j < m; ++j) {
    if (has_lg[j] != 0.0 && lg[j] - p_gz[j] > primal_tol) retry = (p_mode_lg[j] = 1);
    if (has_ug[j] != 0.0 && p_gz[j] - ug[j] > primal_tol) retry = (p_mode_ug[j] = 1);
  }
  if (ne > 0) {
    p_ez.noalias() = E * p_z;
    if (!(inf_norm(p_ez - e) <= primal_tol)) return 0;
  }
  // Gradient of the Lagrangian without the fixed variables' multipliers: those are −grad_i.
  p_grad = p_hz + pr.f;
  for (int r = 0; r < k; ++r) {
    if (p_src[r] >= 0) {
      p_grad.noalias() += p_y[r] * pr.G.row(p_src[r]).transpose();
    } else {
      p_grad.noalias() += p_y[r] * E.row(-p_src[r] - 1).transpose();
    }
  }
  const double dual_scale =
      std::max({1.0, inf_norm(p_hz), inf_norm(pr.f), k > 0 ? inf_norm(p_y.head(k)) : 0.0,
                inf_norm(p_grad)});
  const double dual_tol = tol * dual_scale;
  for (int i = 0; i < n; ++i) {
    if (p_fix[i] == 0 && std::abs(p_grad[i]) > dual_tol) return 0;
    if (p_fix[i] == -1 && p_grad[i] < -dual_tol) retry = (p_mode_lb[i] = -1);  // λ_lb = grad_i
    if (p_fix[i] == 1 && p_grad[i] > dual_tol) retry = (p_mode_ub[i] = -1);    // λ_ub = −grad_i
  }
  for (int r = 0; r < k; ++r) {
    if (p_side[r] == -1 && p_y[r] > dual_tol) retry = (p_mode_lg[p_src[r]] = -1);
    if (p_side[r] == 1 && p_y[r] < -dual_tol) retry = (p_mode_ug[p_src[r]] = -1);
  }
  if (retry) return -1;
  const double objective_ipm = 0.5 * z.dot(Hz) + pr.f.dot(z);
  const double objective = 0.5 * p_z.dot(p_hz) + pr.f.dot(p_z);
  const double gap_scale = std::max({1.0, std::abs(z.dot(Hz)), std::abs(pr.f.dot(z))});
  if (!(objective <= objective_ipm + tol * gap_scale)) return 0;

  // Accept: the polished point with its multipliers, slacks at the constraints' distances.
  z = p_z;
  l_lb.setZero();
  l_ub.setZero();
  l_lg.setZero();
  l_ug.setZero();
  for (int i = 0; i < n; ++i) {
    if (p_fix[i] == -1) l_lb[i] = std::max(0.0, p_grad[i]);
    if (p_fix[i] == 1) l_ub[i] = std::max(0.0, -p_grad[i]);
    if (p_fix[i] == 2) y[eq_row_of_var[i]] = -p_grad[i];
  }
  for (int r = 0; r < k; ++r) {
    if (p_src[r] < 0) {
      y[-p_src[r] - 1] = p_y[r];
    } else if (p_side[r] == -1) {
      l_lg[p_src[r]] = std::max(0.0, -p_y[r]);
    } else {
      l_ug[p_src[r]] = std::max(0.0, p_y[r]);
    }
  }
  if (m > 0) Gz = p_gz;
  s_lb = has_lb * (z.array() - lb).max(0.0) + (1.0 - has_lb);
  s_ub = has_ub * (ub - z.array()).max(0.0) + (1.0 - has_ub);
  s_lg = has_lg * (Gz.array() - lg).max(0.0) + (1.0 - has_lg);
  s_ug = has_ug * (ug - Gz.array()).max(0.0) + (1.0 - has_ug);
  residuals();
  return 1;
}

const QpResult& QpSolver::solve(const QpProblem& problem) {
  const auto start = std::chrono::steady_clock::now();
  QpResult& r = result_;
  r.iterations = 0;
  r.active_set_iterations = 0;
  r.polished = false;
  r.fell_back = false;
  r.method = settings_.method;
  const bool active_set = settings_.method == QpMethod::kActiveSet;
  // The small arrays are fetched at once, so that their misses overlap instead of each scan
  // below waiting for its own (G is fetched during the solve: see DualActiveSet::solve).
  fetch_into_cache(problem.H);
  for (const Eigen::VectorXd* v :
       {&problem.f, &problem.lb, &problem.ub, &problem.lg, &problem.ug}) {
    fetch_into_cache(*v);
  }
  // The active set checks G's entries through the product G·z it ends with (rows_finite),
  // not by a pass of its own before the solve: such a pass would be the first to read G and
  // wait for it from memory when the caller's rows are not in the cache (a stored sequence of
  // problems: about a fifth of a solve of gen_mpc_qps.py's instances), where the solve fetches
  // them while it factors H. Any other outcome checks G in full, before the interior point.
  bool valid = valid_input(problem, /*check_rows=*/!active_set);
  bool answered = false;
  if (valid && active_set) {
    answered = solve_active_set(problem);
    const bool rows_read =
        answered && r.status == QpStatus::kSolved && rows_finite(problem, workspace_->active_set);
    if (!rows_read) valid = all_finite(problem.G);
  }
  if (!valid) {
    r.status = QpStatus::kInvalidInput;
    r.objective = r.primal_residual = r.dual_residual = r.duality_gap = 0.0;
    r.iterations = r.active_set_iterations = 0;
    // A solve that ran on rows found invalid after it leaves no working set to start from.
    if (answered) workspace_->active_set.forget();
  } else if (answered) {
    // Answered by the active-set method.
  } else {
    Workspace& w = *workspace_;
    if (active_set) {
      r.fell_back = true;
      r.method = QpMethod::kInteriorPoint;
    }
    w.setup(problem);
    QpStatus status = QpStatus::kNumericalError;
    int iterations = 0;
    bool done = false;
    if (settings_.warm_start && w.have_previous) {
      w.warm_start();
      status = w.iterate(settings_, std::min(settings_.max_iterations,
                                             settings_.warm_start_max_iterations),
                         iterations);
      r.iterations += iterations;
      done = status == QpStatus::kSolved || status == QpStatus::kPrimalInfeasible ||
             status == QpStatus::kDualInfeasible;
    }
    if (!done) {
      w.cold_start();
      status = w.iterate(settings_, settings_.max_iterations, iterations);
      r.iterations += iterations;
    }
    r.status = status;
    r.polished = status == QpStatus::kSolved && settings_.polish && w.polish(settings_);
    w.fill_result(r);
    if (status == QpStatus::kSolved) {
      w.z_prev = w.z;
      if (w.ne > 0) w.y_prev = w.y;
      w.p_lb = w.l_lb;
      w.p_ub = w.l_ub;
      w.p_lg = w.l_lg;
      w.p_ug = w.l_ug;
      w.have_previous = true;
      // The next active-set solve starts from the sides with nonzero multipliers (exact zeros
      // off the active set when polished, ~μ/s otherwise).
      if (active_set) {
        const double scale = std::max({1.0, inf_norm(r.dual_bounds), inf_norm(r.dual_rows)});
        w.active_set.set_working_set(r, 1e-6 * scale);
      }
    }
  }
  r.solve_time_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
  return r;
}

// QpMethod::kActiveSet: returns true when the dual active-set method answered (solved, or
// infeasible with a checked certificate); false leaves the problem to the interior point.
bool QpSolver::solve_active_set(const QpProblem& problem) {
  Workspace& w = *workspace_;
  QpResult& r = result_;
  const int n = problem.num_variables();
  const int m = static_cast<int>(problem.G.rows()), p = static_cast<int>(problem.A.rows());
  w.active_set.resize(n, m, p);
  // Size the fallback's workspace now, so that a first fallback in the 50 Hz loop does not
  // allocate.
  if (w.n != n || w.m != m || w.p != p) w.setup(problem);
  const int cap = settings_.active_set_max_iterations > 0 ? settings_.active_set_max_iterations
                                                          : 2 * (n + 10);
  // Sides are met to a tenth of the relative tolerance (the interior point's primal residual
  // is scaled by max(1, ‖z‖, ‖Gz‖), which the active set's exact vertices do not need).
  const ActiveSetOutcome outcome =
      w.active_set.solve(problem, settings_.warm_start, cap, 0.1 * settings_.tolerance);
  r.active_set_iterations = w.active_set.iterations();
  r.iterations = r.active_set_iterations;
  if (outcome != ActiveSetOutcome::kSolved && outcome != ActiveSetOutcome::kInfeasible) {
    return false;
  }
  r.status = outcome == ActiveSetOutcome::kSolved ? QpStatus::kSolved : QpStatus::kPrimalInfeasible;
  r.z = w.active_set.z();
  w.active_set.multipliers(r.dual_bounds, r.dual_rows, r.dual_eq);
  r.objective = w.active_set.objective();
  r.primal_residual = w.active_set.primal_residual();
  r.dual_residual = w.active_set.dual_residual();
  r.duality_gap = 0.0;  // complementary by construction: inactive sides have zero multipliers
  // A later fallback starts the interior point cold rather than from an older solution.
  w.have_previous = false;
  return true;
}

}  // namespace ridgeline::qp
