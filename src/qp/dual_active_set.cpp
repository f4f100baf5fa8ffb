// Goldfarb–Idnani dual active-set method; the mathematics is in dual_active_set.hpp.
#include "qp/dual_active_set.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include <Eigen/Householder>

#include "core/simd_clones.hpp"

namespace ridgeline::qp {

namespace {

// Sides at or beyond this magnitude are absent (as in the interior point).
constexpr double kInfiniteBound = 1e20;
// A constraint is dependent on the working set when the part of Jᵀn outside the working set's
// span is below this fraction of the whole (an angle of ~1e-10 rad to the span).
constexpr double kDependence = 1e-10;
// H is taken as not strictly convex when the squared ratio of the Cholesky factor's extreme
// diagonal entries, a lower bound on cond(H), exceeds this: J = L⁻ᵀ would lose all accuracy.
constexpr double kMaxConditionEstimate = 1e14;
// Corrections of the guessed working set the fast path tries before the dual method (see
// try_working_set).
constexpr int kMaxCorrections = 5;

bool finite_side(double v) { return std::abs(v) < kInfiniteBound; }

bool equal_sides(double lo, double hi) {
  return finite_side(lo) && finite_side(hi) &&
         hi - lo <= 1e-12 * std::max(1.0, std::max(std::abs(lo), std::abs(hi)));
}

// Plane rotation taking (a, b) to (h, 0); applied to the pairs (x, y) as (c x + s y, −s x + c y).
struct Rotation {
  double c = 1.0, s = 0.0;
  static Rotation zeroing(double& a, double& b) {
    const double h = std::sqrt(a * a + b * b);  // entries of J and R are far from overflow
    Rotation g{a / h, b / h};
    a = h;
    b = 0.0;
    return g;
  }
  void apply(double& x, double& y) const {
    const double t = c * x + s * y;
    y = -s * x + c * y;
    x = t;
  }
};

// Fetches the next `lines` cache lines of the rows ahead of their first use (see
// DualActiveSet::solve): spread over the columns of the factorizations, the transfers overlap
// their arithmetic instead of stalling the product G·z that first reads the rows.
inline __attribute__((always_inline)) void fetch_ahead(LinePrefetch* fetch, int lines) {
  if (fetch != nullptr) fetch->ahead(lines);
}
// Lines fetched per column of a factorization or triangular solve: at n = 30 the factor of H
// fetches 15 KB of the default instances' 45 KB of G, the working set's solves more, and the
// product reads the rest as it goes; more lines a column stall the column's arithmetic on
// outstanding fetches (measured: 8 and 12 lines best, 24 no better than none).
constexpr int kLinesPerColumn = 8;

// H = LLᵀ, reading H's lower triangle; false unless every pivot is positive. Left-looking
// by columns: column j of L is H's minus the earlier columns k < j weighted by L(j, k), four
// rows at a time with their sums in registers. For the MPC's n ≈ 30 this runs in a fraction of
// the instructions of Eigen's blocked LLT, whose panel products are sized for larger matrices.
// On raw column-major storage (leading dimensions ldh, ldl), so that the active set's small
// Gram matrix uses it too; L may be H (in place).
//
// With `end` (n entries, not in place), each column's envelope is found on the way: end[j] is
// one past the last row of column j of L that can be nonzero. An earlier column k fills
// column j down to end[k] only if its envelope reaches row j (L(j, k) ≠ 0 needs j < end[k]),
// so end[j] is the last nonzero of H's column or, if it reaches further, the largest end of
// the earlier columns when that lies past j — for a block-diagonal H, the end of the block. The
// column is computed down to it and stored as zeros below, so a block-diagonal H (an MPC's
// inputs that no output couples, its slacks) costs its blocks, and the triangular solves stop
// at the same rows. Rows below an envelope are exact zeros either way: only the sign of a zero
// can differ from the whole-column computation.
// inverse_diagonal[j] = 1 / L(j, j) (n entries): the column below the pivot is scaled by it,
// and the substitutions below multiply by it instead of dividing (a division in their chains
// of dependent operations costs as much as several multiplications; the results differ in
// round-off only).
RIDGELINE_SIMD_CLONES bool cholesky_lower(const double* H, Eigen::Index ldh, double* L,
                                          Eigen::Index ldl, Eigen::Index n, int* end,
                                          double* __restrict inverse_diagonal,
                                          LinePrefetch* fetch = nullptr) {
  const auto L_at = [&](Eigen::Index i, Eigen::Index k) { return L[k * ldl + i]; };
  // The largest end[k] of the columns so far; end[] never decreases (each column's end is at
  // least this), so the first column whose envelope reaches row j only moves down: the columns
  // before it add nothing to column j.
  Eigen::Index reach = 0;
  Eigen::Index first_coupled = 0;
  for (Eigen::Index j = 0; j < n; ++j) {
    double* __restrict col = L + j * ldl;
    const double* h = H + j * ldh;
    Eigen::Index last = n;
    if (end != nullptr) {
      // H's last nonzero below: four entries a test from the bottom up, then one by one.
      const Eigen::Index lowest = std::max(j + 1, reach);
      last = lowest;
      Eigen::Index i = n;
      const Vec4 zero = {};
      for (; i - 4 >= lowest; i -= 4) {
        Vec4 v;
        std::memcpy(&v, h + i - 4, sizeof v);
        const Mask4 nonzero = Mask4(v != zero);  // a NaN counts as nonzero
        if ((nonzero[0] | nonzero[1] | nonzero[2] | nonzero[3]) == 0) continue;
        last = i - (nonzero[3] != 0 ? 0 : nonzero[2] != 0 ? 1 : nonzero[1] != 0 ? 2 : 3);
        i = lowest;  // found
        break;
      }
      for (; i > lowest; --i) {
        if (h[i - 1] != 0.0) {
          last = i;
          break;
        }
      }
      end[j] = static_cast<int>(last);
      reach = std::max(reach, last);
    }
    fetch_ahead(fetch, kLinesPerColumn);
    if (h != col) {
      for (Eigen::Index i = j; i < last; ++i) col[i] = h[i];
    }
    // Column j minus Σ_k L(j, k)·L(i, k) over the earlier columns whose envelopes reach row j,
    // k ascending: four rows a pass with their sums in a register, each L(i, k) loaded once
    // (the columns are short: about ten rows in a 20-column block). Each term is one
    // multiply-subtract, in the order a column at a time gave (k = 0, 1, …), so the values are
    // the same (only an exact zero's sign can differ: a zero L(j, k) is no longer skipped).
    Eigen::Index k0 = 0;
    if (end != nullptr) {
      while (first_coupled < j && end[first_coupled] <= j) ++first_coupled;
      k0 = first_coupled;
    }
    // With an envelope (not in place) the rows below it are overwritten with zeros further
    // down, so a last pass of four may run past `last` while it stays inside the column; those
    // rows start from zero (not whatever the storage held), and the earlier columns are zero
    // there too (below their envelopes), so they sum exact zeros. Where the pass cannot run
    // past `last` (in place, or at the column's end), the rows left over go one by one.
    const Eigen::Index four_rows_end = end != nullptr ? std::min(last + 3, n) : last;
    for (Eigen::Index r = last; r < four_rows_end; ++r) col[r] = 0.0;
    Eigen::Index i = j;
    for (; i + 4 <= four_rows_end; i += 4) {
      Vec4 sum;
      std::memcpy(&sum, col + i, sizeof sum);
      for (Eigen::Index k = k0; k < j; ++k) {
        Vec4 lik;
        std::memcpy(&lik, L + k * ldl + i, sizeof lik);
        sum = sum - L_at(j, k) * lik;
      }
      std::memcpy(col + i, &sum, sizeof sum);
    }
    for (; i < last; ++i) {
      double v = col[i];
      for (Eigen::Index k = k0; k < j; ++k) v = v - L_at(j, k) * L_at(i, k);
      col[i] = v;
    }
    const double pivot = col[j];
    if (!(pivot > 0.0)) return false;
    const double d = std::sqrt(pivot);
    col[j] = d;
    const double inverse = 1.0 / d;
    inverse_diagonal[j] = inverse;
    for (Eigen::Index i = j + 1; i < last; ++i) col[i] *= inverse;
    for (Eigen::Index i = last; i < n; ++i) col[i] = 0.0;
  }
  return true;
}

// Rows [first, n) of the Cholesky factor L of H (both column-major, H's lower triangle read),
// rows [0, first) being already H's: when only the matrix's later rows and columns changed,
// its factor's leading rows stay, and each later row is computed from the rows above it
// (L(b, a) = (H(b, a) − Σ_{m<a} L(a, m)·L(b, m)) / L(a, a), then the pivot), the terms in the
// order cholesky_lower sums them. Row by row in scalars: the fast path's factors are a few
// dozen rows, and a correction changes one or a few of them. False unless every pivot is
// positive.
RIDGELINE_SIMD_CLONES bool cholesky_rows(const double* H, Eigen::Index ldh, double* L,
                                         Eigen::Index ldl, Eigen::Index first, Eigen::Index n,
                                         double* __restrict inverse_diagonal) {
  for (Eigen::Index b = first; b < n; ++b) {
    for (Eigen::Index a = 0; a < b; ++a) {
      double v = H[a * ldh + b];
      for (Eigen::Index m = 0; m < a; ++m) v = v - L[m * ldl + a] * L[m * ldl + b];
      L[a * ldl + b] = v * inverse_diagonal[a];
    }
    double pivot = H[b * ldh + b];
    for (Eigen::Index m = 0; m < b; ++m) pivot = pivot - L[m * ldl + b] * L[m * ldl + b];
    if (!(pivot > 0.0)) return false;
    const double d = std::sqrt(pivot);
    L[b * ldl + b] = d;
    inverse_diagonal[b] = 1.0 / d;
  }
  return true;
}

// L_ = chol(H) with its envelope (the active set's factor).
bool cholesky_lower(const Eigen::MatrixXd& H, Eigen::MatrixXd& L, int* end,
                    double* inverse_diagonal, LinePrefetch* fetch) {
  return cholesky_lower(H.data(), H.outerStride(), L.data(), L.outerStride(), H.rows(), end,
                        inverse_diagonal, fetch);
}

// max |L(j, j)| / min |L(j, j)| of a Cholesky factor: its square estimates the condition
// number of the factored matrix.
double diagonal_ratio(const double* L, Eigen::Index ld, Eigen::Index n) {
  double dmax = 0.0, dmin = std::numeric_limits<double>::infinity();
  for (Eigen::Index j = 0; j < n; ++j) {
    dmax = std::max(dmax, std::abs(L[j * ld + j]));
    dmin = std::min(dmin, std::abs(L[j * ld + j]));
  }
  return dmax / dmin;
}

// Σ a[i]·b[i] over [0, n) in four interleaved partial sums (a fixed order, so the result is
// reproducible; Eigen's reductions reassociate too).
inline __attribute__((always_inline)) double dot(const double* __restrict a,
                                                 const double* __restrict b, Eigen::Index n) {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  Eigen::Index i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += a[i] * b[i];
    s1 += a[i + 1] * b[i + 1];
    s2 += a[i + 2] * b[i + 2];
    s3 += a[i + 3] * b[i + 3];
  }
  for (; i < n; ++i) s0 += a[i] * b[i];
  return (s0 + s1) + (s2 + s3);
}

// y ← L⁻¹y for lower-triangular L (column-major, leading dimension ld): forward substitution
// down L's columns, contiguous axpys; a zero stays zero without its axpy.
// With `end` (cholesky_lower's envelope), each axpy stops where its column's nonzeros do.
RIDGELINE_SIMD_CLONES void forward_substitute(const double* L, Eigen::Index ld, Eigen::Index n,
                                              const double* inverse_diagonal, double* __restrict y,
                                              const int* end) {
  for (Eigen::Index j = 0; j < n; ++j) {
    if (y[j] == 0.0) continue;
    const double* __restrict l = L + j * ld;
    y[j] *= inverse_diagonal[j];
    const double a = y[j];
    const Eigen::Index last = end != nullptr ? end[j] : n;
    for (Eigen::Index i = j + 1; i < last; ++i) y[i] -= a * l[i];
  }
}

// x ← L⁻ᵀx: x_j = (x_j − Σ_{i>j} L(i, j)·x_i)·(1 / L(j, j)) from the last j, each sum a dot
// product down a column of L.
// With `end`, each dot product stops at the first whole four of terms past its column's
// nonzeros (or at n): the terms it leaves out are exact zeros, and the ones it keeps go to the
// same partial sums as over the whole column.
RIDGELINE_SIMD_CLONES void back_substitute_transposed(const double* L, Eigen::Index ld,
                                                      Eigen::Index n,
                                                      const double* inverse_diagonal,
                                                      double* __restrict x, const int* end) {
  for (Eigen::Index j = n - 1; j >= 0; --j) {
    const double* l = L + j * ld;
    Eigen::Index count = n - j - 1;
    if (end != nullptr) count = std::min(count, (end[j] - j - 1 + 3) / 4 * 4);
    x[j] = (x[j] - dot(l + j + 1, x + j + 1, count)) * inverse_diagonal[j];
  }
}

// Rows [first, k) of S's lower triangle = YᵀY for the first k columns of Y (n rows),
// column-major S: S(b, a) = y_bᵀy_a for a ≤ b, the rows of the sides that joined since the
// rows before them were formed (first = 0: all of it).
RIDGELINE_SIMD_CLONES void gram_rows(const Eigen::MatrixXd& Y, Eigen::Index n, int first, int k,
                                     double* S, Eigen::Index lds, LinePrefetch* fetch) {
  for (int b = first; b < k; ++b) {
    fetch_ahead(fetch, kLinesPerColumn);
    const double* yb = Y.col(b).data();
    for (int a = 0; a <= b; ++a) S[a * lds + b] = dot(yb, Y.col(a).data(), n);
  }
}

// Y[:, first..k) ← L⁻¹Y by forward substitution, column by column: each step is a contiguous
// axpy down a column of L (Eigen's blocked triangular solve is sized for larger matrices),
// stopping at the column's envelope (cholesky_lower).
RIDGELINE_SIMD_CLONES void solve_lower_columns(const Eigen::MatrixXd& L, const int* end,
                                               const double* inverse_diagonal, Eigen::MatrixXd& Y,
                                               int first, int k, LinePrefetch* fetch = nullptr) {
  const Eigen::Index n = L.rows();
  for (int c = first; c < k; ++c) {
    fetch_ahead(fetch, kLinesPerColumn);
    double* __restrict y = Y.col(c).data();
    for (Eigen::Index j = 0; j < n; ++j) {
      if (y[j] == 0.0) continue;  // a normal's leading zeros stay zero
      y[j] *= inverse_diagonal[j];
      const double a = y[j];
      const double* __restrict l = L.col(j).data();
      for (Eigen::Index i = j + 1; i < end[j]; ++i) y[i] -= a * l[i];
    }
  }
}

// out[0..m) = G[0..m, :]·x for column-major G: one contiguous axpy per column of G.
RIDGELINE_SIMD_CLONES void product_columns(const Eigen::MatrixXd& G, int m,
                                           const Eigen::VectorXd& x, double* __restrict out) {
  std::fill_n(out, m, 0.0);
  for (Eigen::Index c = 0; c < G.cols(); ++c) {
    const double a = x[c];
    const double* __restrict g = G.col(c).data();
    for (int i = 0; i < m; ++i) out[i] += a * g[i];
  }
}

// The rows j < m of a side beyond the tolerance, lo_j − gx_j > tolerance·max(1, |lo_j|) or
// gx_j − hi_j > tolerance·max(1, |hi_j|) for a finite side (most_violated's first test, the
// same expressions), four rows a test; their indices in increasing order go to out. Returns
// how many.
RIDGELINE_SIMD_CLONES int rows_beyond_tolerance(const double* lo, const double* hi,
                                                const double* gx, int m, double tolerance,
                                                int* __restrict out) {
  const Vec4 one = {1.0, 1.0, 1.0, 1.0};
  const Vec4 big = {kInfiniteBound, kInfiniteBound, kInfiniteBound, kInfiniteBound};
  const Vec4 tol = {tolerance, tolerance, tolerance, tolerance};
  int count = 0, j = 0;
  for (; j + 4 <= m; j += 4) {
    Vec4 l, h, g;
    std::memcpy(&l, lo + j, sizeof l);
    std::memcpy(&h, hi + j, sizeof h);
    std::memcpy(&g, gx + j, sizeof g);
    Vec4 abs_l = l, abs_h = h;
    make_magnitude(abs_l);
    make_magnitude(abs_h);
    // max(1, |side|) as std::max(1.0, |side|) gives it: |side| where 1 < |side|, else 1.
    const Mask4 beyond = ((abs_l < big) & ((l - g) > tol * (one < abs_l ? abs_l : one))) |
                         ((abs_h < big) & ((g - h) > tol * (one < abs_h ? abs_h : one)));
    if ((beyond[0] | beyond[1] | beyond[2] | beyond[3]) == 0) continue;
    for (int k = 0; k < 4; ++k) {
      if (beyond[k] != 0) out[count++] = j + k;
    }
  }
  for (; j < m; ++j) {
    if ((finite_side(lo[j]) && lo[j] - gx[j] > tolerance * std::max(1.0, std::abs(lo[j]))) ||
        (finite_side(hi[j]) && gx[j] - hi[j] > tolerance * std::max(1.0, std::abs(hi[j])))) {
      out[count++] = j;
    }
  }
  return count;
}

// J[:, q..n) ← J[:, q..n)·(I − τvvᵀ) with v = [1; essential] (Eigen's
// applyHouseholderOnTheRight, whose rank-one update is SSE2): w = Jv, then J −= τwvᵀ, both
// column by column as contiguous axpys. w has J.rows() entries of workspace.
RIDGELINE_SIMD_CLONES void apply_householder_right(Eigen::MatrixXd& J, int q,
                                                   const double* essential, double tau,
                                                   double* __restrict w) {
  if (tau == 0.0) return;
  const Eigen::Index n = J.rows();
  const Eigen::Index cols = J.cols() - q;
  std::fill_n(w, n, 0.0);
  for (Eigen::Index c = 1; c < cols; ++c) {
    const double a = essential[c - 1];
    const double* __restrict col = J.col(q + c).data();
    for (Eigen::Index i = 0; i < n; ++i) w[i] += a * col[i];
  }
  double* __restrict first = J.col(q).data();
  for (Eigen::Index i = 0; i < n; ++i) w[i] += first[i];
  for (Eigen::Index i = 0; i < n; ++i) first[i] -= tau * w[i];
  for (Eigen::Index c = 1; c < cols; ++c) {
    const double a = tau * essential[c - 1];
    double* __restrict col = J.col(q + c).data();
    for (Eigen::Index i = 0; i < n; ++i) col[i] -= a * w[i];
  }
}

void rotate_columns(Eigen::MatrixXd& J, int a, int b, const Rotation& g) {
  double* ca = J.col(a).data();
  double* cb = J.col(b).data();
  for (Eigen::Index i = 0; i < J.rows(); ++i) g.apply(ca[i], cb[i]);
}

}  // namespace

void DualActiveSet::resize(int n, int m, int p) {
  if (n != n_ || p != p_) {
    n_ = n;
    p_ = p;
    L_.setZero(n, n);
    l_end_.assign(n, n);
    J_.setZero(n, n);
    R_.setZero(n, n);
    Y_.setZero(n, n);
    S_.setZero(n, n);
    gram_.setZero(n, n);
    for (Eigen::VectorXd* v : {&x_, &u_, &d_, &step_, &r_, &jtf_, &v_, &hx_, &res_, &dual_bounds_,
                               &l_inverse_diagonal_, &s_inverse_diagonal_}) {
      v->setZero(n);
    }
    dual_eq_.setZero(p);
    active_.assign(n, Side{});
    saved_.assign(n, Side{});
    count_ = saved_count_ = 0;
  }
  if (m > m_capacity_) {
    m_capacity_ = m;
    gx_.setZero(m);
    candidates_.assign(m, 0);
  }
  m_ = m;
}

bool DualActiveSet::is_equality(Side c) const {
  switch (c.kind) {
    case kLower:
      return q_->lb.size() != 0 && q_->ub.size() != 0 &&
             equal_sides(q_->lb[c.index], q_->ub[c.index]);
    case kRowLower:
      return equal_sides(q_->lg[c.index], q_->ug[c.index]);
    case kEqualityRow:
      return true;
    default:
      return false;
  }
}

double DualActiveSet::normal_dot(Side c, const Eigen::VectorXd& v) const {
  switch (c.kind) {
    case kLower:
      return v[c.index];
    case kUpper:
      return -v[c.index];
    case kRowLower:
      return q_->G.row(c.index).dot(v);
    case kRowUpper:
      return -q_->G.row(c.index).dot(v);
    default:
      return q_->A.row(c.index).dot(v);
  }
}

double DualActiveSet::value(Side c) const {
  switch (c.kind) {
    case kLower:
      return q_->lb[c.index];
    case kUpper:
      return -q_->ub[c.index];
    case kRowLower:
      return q_->lg[c.index];
    case kRowUpper:
      return -q_->ug[c.index];
    default:
      return q_->b[c.index];
  }
}

double DualActiveSet::norm(Side c) const {
  if (c.kind == kLower || c.kind == kUpper) return 1.0;
  if (c.kind == kEqualityRow) return q_->A.row(c.index).norm();
  return q_->G.row(c.index).norm();
}

void DualActiveSet::add_normal(Side c, double a, Eigen::Ref<Eigen::VectorXd> out) const {
  switch (c.kind) {
    case kLower:
      out[c.index] += a;
      break;
    case kUpper:
      out[c.index] -= a;
      break;
    case kRowLower:
      out.noalias() += a * q_->G.row(c.index).transpose();
      break;
    case kRowUpper:
      out.noalias() -= a * q_->G.row(c.index).transpose();
      break;
    default:
      out.noalias() += a * q_->A.row(c.index).transpose();
  }
}

void DualActiveSet::jt_normal(Side c) {
  switch (c.kind) {
    case kLower:
      d_ = J_.row(c.index).transpose();
      break;
    case kUpper:
      d_ = -J_.row(c.index).transpose();
      break;
    case kRowLower:
      d_.noalias() = J_.transpose() * q_->G.row(c.index).transpose();
      break;
    case kRowUpper:  // −(Jᵀg) as two steps: a negated product would need a temporary
      d_.noalias() = J_.transpose() * q_->G.row(c.index).transpose();
      d_ = -d_;
      break;
    default:
      d_.noalias() = J_.transpose() * q_->A.row(c.index).transpose();
  }
}

// Reflects d₂ = d[q..n) onto its first entry (one Householder reflection P, J₂ ← J₂P, so that
// (JP)ᵀn = Pd stays consistent); R gains the column d[0..q]. A reflection costs 4n(n−q) flops
// in two vectorized passes against 6n(n−q) for n−q−1 plane rotations.
bool DualActiveSet::add(Side c) {
  if (count_ >= n_) return false;
  jt_normal(c);
  const int q = count_;
  const double d2_norm = d_.tail(n_ - q).norm();
  if (!(d2_norm > kDependence * d_.norm())) return false;
  if (q + 1 < n_) {
    double tau = 0.0, beta = 0.0;
    d_.tail(n_ - q).makeHouseholderInPlace(tau, beta);
    apply_householder_right(J_, q, d_.data() + q + 1, tau, step_.data());
    d_[q] = beta;
  }
  R_.col(q).head(q + 1) = d_.head(q + 1);
  active_[q] = c;
  ++count_;
  return true;
}

// Removes column k of R; the Hessenberg part left behind is re-triangularized by rotations of
// rows (j, j+1) of R, and the same rotations of columns (j, j+1) of J keep L⁻¹N = Q₁R.
void DualActiveSet::drop(int k) {
  const int q = count_;
  for (int j = k; j < q - 1; ++j) {
    R_.col(j).head(j + 2) = R_.col(j + 1).head(j + 2);
    active_[j] = active_[j + 1];
    u_[j] = u_[j + 1];
  }
  for (int j = k; j < q - 1; ++j) {
    const Rotation g = Rotation::zeroing(R_(j, j), R_(j + 1, j));
    for (int l = j + 1; l < q - 1; ++l) g.apply(R_(j, l), R_(j + 1, l));
    rotate_columns(J_, j, j + 1, g);
  }
  R_.col(q - 1).setZero();
  --count_;
}

void DualActiveSet::solve_working_set() {
  const int q = count_;
  jtf_.noalias() = J_.transpose() * q_->f;
  for (int j = 0; j < q; ++j) v_[j] = value(active_[j]);
  auto Rq = R_.topLeftCorner(q, q).triangularView<Eigen::Upper>();
  if (q > 0) Rq.transpose().solveInPlace(v_.head(q));
  x_.noalias() = J_.rightCols(n_ - q) * jtf_.tail(n_ - q);
  x_ = -x_;
  if (q > 0) {
    x_.noalias() += J_.leftCols(q) * v_.head(q);
    u_.head(q) = v_.head(q) + jtf_.head(q);
    Rq.solveInPlace(u_.head(q));
  }
}

// The inequality side with the largest violation per unit normal beyond the tolerance.
bool DualActiveSet::most_violated(Side& c, double& violation) {
  const QpProblem& q = *q_;
  double worst = 0.0;
  bool found = false;
  if (q.lb.size() != 0) {
    for (int i = 0; i < n_; ++i) {
      const double lo = q.lb[i], hi = q.ub.size() != 0 ? q.ub[i] : kInfinity;
      if (equal_sides(lo, hi)) continue;
      if (finite_side(lo) && lo - x_[i] > tolerance_ * std::max(1.0, std::abs(lo)) &&
          lo - x_[i] > worst) {
        worst = lo - x_[i];
        c = Side{kLower, i};
        found = true;
      }
    }
  }
  if (q.ub.size() != 0) {
    for (int i = 0; i < n_; ++i) {
      const double hi = q.ub[i], lo = q.lb.size() != 0 ? q.lb[i] : -kInfinity;
      if (equal_sides(lo, hi)) continue;
      if (finite_side(hi) && x_[i] - hi > tolerance_ * std::max(1.0, std::abs(hi)) &&
          x_[i] - hi > worst) {
        worst = x_[i] - hi;
        c = Side{kUpper, i};
        found = true;
      }
    }
  }
  if (m_live_ > 0) {
    product_columns(q.G, m_live_, x_, gx_.data());
    // The rows that fail the first test below, found four at a time; the others pass both.
    const int candidates = rows_beyond_tolerance(q.lg.data(), q.ug.data(), gx_.data(), m_live_,
                                                 tolerance_, candidates_.data());
    for (int k = 0; k < candidates; ++k) {
      const int j = candidates_[k];
      const double lo = q.lg[j], hi = q.ug[j];
      if (equal_sides(lo, hi)) continue;
      // The tolerance is tolerance·max(1, ‖g‖, |side|); ‖g‖ is computed only for the rows
      // that fail the cheaper test without it.
      const double below = lo - gx_[j], above = gx_[j] - hi;
      if (finite_side(lo) && below > tolerance_ * std::max(1.0, std::abs(lo))) {
        const double g_norm = q.G.row(j).norm();
        if (below > tolerance_ * std::max(g_norm, std::abs(lo)) && below > worst * g_norm) {
          worst = below / g_norm;
          c = Side{kRowLower, j};
          found = true;
        }
      }
      if (finite_side(hi) && above > tolerance_ * std::max(1.0, std::abs(hi))) {
        const double g_norm = q.G.row(j).norm();
        if (above > tolerance_ * std::max(g_norm, std::abs(hi)) && above > worst * g_norm) {
          worst = above / g_norm;
          c = Side{kRowUpper, j};
          found = true;
        }
      }
    }
  }
  violation = worst;
  return found;
}

bool DualActiveSet::usable(Side c) const {
  const QpProblem& q = *q_;
  switch (c.kind) {
    case kLower:
      return q.lb.size() != 0 && finite_side(q.lb[c.index]) && !is_equality(c);
    case kUpper:
      return q.ub.size() != 0 && finite_side(q.ub[c.index]) &&
             !is_equality(Side{kLower, c.index});
    case kRowLower:
      return c.index < m_ && finite_side(q.lg[c.index]) && !is_equality(c);
    case kRowUpper:
      return c.index < m_ && finite_side(q.ug[c.index]) && !is_equality(Side{kRowLower, c.index});
    default:
      return false;
  }
}

// The fast path. When the previous working set is still optimal (the common case in MPC: the
// median solve on the gen_mpc_qps.py sequence), the equality-constrained minimizer on it is
// feasible and its multipliers are nonnegative, and nothing else is needed. It is computed by
// the range-space (Schur complement) method: with H = LLᵀ, Y = L⁻¹N, g = L⁻¹f,
//   (YᵀY) u = b + Yᵀg,   z = L⁻ᵀ(Yu − g),
// for n²q + nq²/2 flops against the n³/3 of J = L⁻ᵀ and the q reflections (1) needs.
// When a check fails, the guess is corrected and solved again, kMaxCorrections times at most:
// the inequality with the most negative multiplier leaves the working set, or else the most
// violated side joins it (an MPC's working set mostly gains or loses one side from a period to
// the next), or, when the side that joined lies in the span of the others, the side the dual
// method's ratio test picks leaves for it; within max_iterations (each correction counts as
// one). A correction forms only
// what changed: a side that joins adds its column of Y, its row of the Gram matrix YᵀY (k dot
// products) and one row of the Gram matrix's factor; a side that leaves gives its place to the
// last one, whose Gram entries move with it, and the factor's rows from that place on are
// computed again (the rows before it are the same). Before, each correction formed YᵀY again
// (k²n/2 flops), and a failed one cost so much in the slow solves of gen_mpc_qps.py that the
// corrections were limited to working sets of n/2 sides; in `bench mpc` nearly every solve the
// dual method made was one at 16–23 sides, one to three sides off its guess. Five corrections:
// with three, gen_mpc_qps.py's p99 was 2.8–3.0 times its median, with five 2.77 (its p90 17 µs
// in both, against 29 µs with the n/2 limit). A point is accepted only by the checks of an
// optimum (every side met, every inequality multiplier nonnegative, stationarity), so a
// correction that does not lead to the optimum costs time, never the answer: when the
// corrections run out, or the guess's sides are nearly dependent, or no side can leave for one
// that joins in their span, the dual method starts from the previous working set, as without
// them.
bool DualActiveSet::try_working_set(bool hot_start, int max_iterations) {
  const QpProblem& q = *q_;
  count_ = 0;
  if (p_ > n_) return false;  // more equality rows than variables: the dual method sorts them
  for (int k = 0; k < p_; ++k) active_[count_++] = Side{kEqualityRow, k};
  for (int j = 0; j < m_live_ && count_ < n_; ++j) {
    if (is_equality(Side{kRowLower, j})) active_[count_++] = Side{kRowLower, j};
  }
  for (int i = 0; i < n_ && q.lb.size() != 0 && count_ < n_; ++i) {
    if (is_equality(Side{kLower, i})) active_[count_++] = Side{kLower, i};
  }
  const int equalities = count_;
  for (int k = 0; hot_start && k < saved_count_ && count_ < n_; ++k) {
    if (usable(saved_[k])) active_[count_++] = saved_[k];
  }
  // The small dense kernels below are hand-written: at n ≈ 33 and a working set of a few
  // sides, Eigen's blocked triangular solves, rank update and LLT cost several times their
  // arithmetic (about 20 k instructions of the MPC's step).
  const Eigen::Index n = n_;
  jtf_ = q.f;  // g = L⁻¹f
  const double* l_inverse = l_inverse_diagonal_.data();
  forward_substitute(L_.data(), L_.outerStride(), n, l_inverse, jtf_.data(), l_end_.data());
  // The sides active_[0, computed) have their columns of Y and their rows of the Gram matrix
  // YᵀY; the first `factored` columns of its factor are current.
  int computed = 0, factored = 0;
  bool joined = false;  // the last correction added a side (the working set's last)
  // Another correction is tried (see above).
  const auto may_correct = [&](int correction) {
    return correction < kMaxCorrections && iterations_ < max_iterations;
  };
  double* gram = gram_.data();
  const Eigen::Index ldg = gram_.outerStride();
  double* S = S_.data();
  const Eigen::Index lds = S_.outerStride();
  double* s_inverse = s_inverse_diagonal_.data();
  // Side `leaving` of the k in the working set leaves it: the last side takes its place (the
  // order of the working set is immaterial), with its column of Y and its Gram entries
  // (y_bᵀy_a = y_aᵀy_b to the bit: the same products summed in the same order), and the
  // factor is computed again from that row on.
  const auto leave = [&](int leaving, int k) {
    const int last = k - 1;
    if (leaving < last) {
      active_[leaving] = active_[last];
      Y_.col(leaving) = Y_.col(last);
      for (int a = 0; a < leaving; ++a) gram[a * ldg + leaving] = gram[a * ldg + last];
      gram[leaving * ldg + leaving] = gram[last * ldg + last];
      for (int b = leaving + 1; b < last; ++b) gram[leaving * ldg + b] = gram[b * ldg + last];
    }
    computed = --count_;
    factored = std::min(factored, leaving);
    joined = false;
    ++iterations_;
  };
  for (int correction = 0;; ++correction) {
    const int k = count_;
    x_ = -jtf_;
    if (k > 0) {
      for (int j = computed; j < k; ++j) {
        Y_.col(j).setZero();
        add_normal(active_[j], 1.0, Y_.col(j));
      }
      solve_lower_columns(L_, l_end_.data(), l_inverse, Y_, computed, k, &fetch_);
      // YᵀY = NᵀH⁻¹N: the rows of the sides that joined, then its factor S: in full the first
      // time, after a correction from the first row that changed (the rows before it depend
      // only on the sides before it).
      gram_rows(Y_, n, computed, k, gram, ldg, &fetch_);
      factored = std::min(factored, computed);
      computed = k;
      const bool factor_ok = factored == 0
                                 ? cholesky_lower(gram, ldg, S, lds, k, nullptr, s_inverse)
                                 : cholesky_rows(gram, ldg, S, lds, factored, k, s_inverse);
      const double ratio = factor_ok ? diagonal_ratio(S, lds, k) : kInfinity;
      if (!(ratio * ratio < 1e12)) {  // dependent or nearly dependent sides
        // When a side has just joined a working set whose factor passed this test, and its
        // pivot failed or is the smallest (not a badly scaled side, whose pivot is the
        // largest), it lies (nearly) in the span of the others, n_p = N r in H⁻¹'s metric: as
        // the dual method's step without a primal part, the side whose multiplier u_j − t·r_j
        // reaches zero first as p's grows by t leaves for it (the rows of S before the last are
        // the working set's factor, and the last row's entries before its pivot are
        // w = S⁻¹Yᵀy_p, so r = S⁻ᵀw). Otherwise the dual method decides (infeasible, or
        // dependent equalities).
        if (!joined || factored != k - 1 || !may_correct(correction)) return false;
        if (factor_ok) {
          const double pivot = S[(k - 1) * lds + k - 1];
          for (int j = 0; j < k - 1; ++j) {
            if (S[j * lds + j] < pivot) return false;
          }
        }
        for (int a = 0; a < k - 1; ++a) r_[a] = S[a * lds + k - 1];
        back_substitute_transposed(S, lds, k - 1, s_inverse, r_.data(), nullptr);
        int leaving = -1;
        for (int j = equalities; j < k - 1; ++j) {
          if (r_[j] > 0.0 && (leaving < 0 || u_[j] * r_[leaving] < u_[leaving] * r_[j])) {
            leaving = j;
          }
        }
        if (leaving < 0) return false;
        leave(leaving, k);
        continue;
      }
      factored = k;
      for (int j = 0; j < k; ++j) {
        u_[j] = value(active_[j]) + dot(Y_.col(j).data(), jtf_.data(), n);
      }
      forward_substitute(S, lds, k, s_inverse, u_.data(), nullptr);
      back_substitute_transposed(S, lds, k, s_inverse, u_.data(), nullptr);
      const double u_scale = std::max(1.0, u_.head(k).cwiseAbs().maxCoeff());
      int negative = -1;
      for (int j = equalities; j < k; ++j) {
        if (u_[j] < -tolerance_ * u_scale && (negative < 0 || u_[j] < u_[negative])) {
          negative = j;
        }
      }
      if (negative >= 0) {
        if (!may_correct(correction)) return false;
        leave(negative, k);
        continue;
      }
      for (int j = equalities; j < k; ++j) u_[j] = std::max(u_[j], 0.0);
      for (int j = 0; j < k; ++j) {  // x += Y u
        const double a = u_[j];
        const double* y = Y_.col(j).data();
        for (Eigen::Index i = 0; i < n; ++i) x_[i] += a * y[i];
      }
    }
    back_substitute_transposed(L_.data(), L_.outerStride(), n, l_inverse, x_.data(), l_end_.data());
    Side p;
    double violation = 0.0;
    if (!most_violated(p, violation)) break;
    if (count_ >= n_ || !may_correct(correction)) return false;
    active_[count_++] = p;
    joined = true;
    ++iterations_;
  }
  if (!finish(true)) return false;
  fast_path_ = true;
  saved_count_ = 0;  // the next hot start's guess: this working set's inequalities
  for (int j = equalities; j < count_; ++j) saved_[saved_count_++] = active_[j];
  return true;
}

// w = (−r on the working set, 1 on p): Σ wᵢnᵢ should vanish and wᵀb be positive. For any z,
// wᵀ(Nᵀz − b) = (Σ wᵢnᵢ)ᵀz − wᵀb, so a feasible z (every term ≥ 0, equalities 0) would need
// ‖Σ wᵢnᵢ‖∞ ‖z‖₁ ≥ wᵀb: the certificate proves that no feasible point has
// ‖z‖₁ ≤ R = 10·max(1, ‖z_k‖₁), the same test as the interior point's fallback certificate.
bool DualActiveSet::check_certificate(Side p) {
  res_.setZero();
  add_normal(p, 1.0, res_);
  double wb = value(p);
  double w_max = 1.0;
  for (int j = 0; j < count_; ++j) {
    add_normal(active_[j], -r_[j], res_);
    wb -= r_[j] * value(active_[j]);
    w_max = std::max(w_max, std::abs(r_[j]));
  }
  const double radius = 10.0 * std::max(1.0, x_.lpNorm<1>());
  const double residual = res_.cwiseAbs().maxCoeff();
  return wb > 1e-9 * w_max && residual * radius < wb;
}

ActiveSetOutcome DualActiveSet::solve(const QpProblem& q, bool hot_start, int max_iterations,
                                      double tolerance) {
  q_ = &q;
  tolerance_ = tolerance;
  m_live_ = m_;
  while (m_live_ > 0 && !finite_side(q.lg[m_live_ - 1]) && !finite_side(q.ug[m_live_ - 1])) {
    --m_live_;
  }
  iterations_ = 0;
  count_ = 0;
  fast_path_ = false;
  // The general rows are read whole first by the product G·z, after the factorizations (the
  // hot start's rows, a few lines of each column, before); a caller's rows that are not in the
  // cache (a stored sequence of problems) are fetched during them, a few lines a column (for
  // rows the caller has just written, the fetches find them in the cache and cost about one
  // instruction a line).
  fetch_.base = reinterpret_cast<const char*>(q.G.data());
  fetch_.next = 0;
  fetch_.bytes = static_cast<std::size_t>(q.G.size()) * sizeof(double);
  if (!cholesky_lower(q.H, L_, l_end_.data(), l_inverse_diagonal_.data(), &fetch_)) {
    return ActiveSetOutcome::kNotStrictlyConvex;
  }
  const double ratio = diagonal_ratio(L_.data(), L_.outerStride(), n_);
  if (!(ratio * ratio < kMaxConditionEstimate)) return ActiveSetOutcome::kNotStrictlyConvex;
  if (try_working_set(hot_start, max_iterations)) return ActiveSetOutcome::kSolved;
  iterations_ = 0;  // the corrections tried are not the dual method's
  count_ = 0;
  // J = L⁻ᵀ, the transpose of L⁻¹ = L⁻¹I by the forward substitution of the fast path (the
  // identity's leading zeros are skipped; Y_ is free once the fast path has failed).
  Y_.setIdentity();
  solve_lower_columns(L_, l_end_.data(), l_inverse_diagonal_.data(), Y_, 0, n_);
  J_ = Y_.transpose();
  R_.setZero();

  // Equalities first (always in the working set), then the previous inequalities.
  for (int k = 0; k < p_; ++k) add(Side{kEqualityRow, k});
  for (int j = 0; j < m_live_; ++j) {
    if (is_equality(Side{kRowLower, j})) add(Side{kRowLower, j});
  }
  for (int i = 0; i < n_ && q.lb.size() != 0; ++i) {
    if (is_equality(Side{kLower, i})) add(Side{kLower, i});
  }
  const int equalities = count_;
  if (hot_start) {
    for (int k = 0; k < saved_count_; ++k) {
      if (usable(saved_[k])) add(saved_[k]);
    }
  }
  solve_working_set();
  // Make the start dual feasible: drop the most negative inequality multiplier until none is.
  for (;;) {
    int worst = -1;
    for (int j = equalities; j < count_; ++j) {
      if (u_[j] < 0.0 && (worst < 0 || u_[j] < u_[worst])) worst = j;
    }
    if (worst < 0) break;
    drop(worst);
    solve_working_set();
  }

  Side p;
  double violation = 0.0;
  while (most_violated(p, violation)) {
    if (++iterations_ > max_iterations) return ActiveSetOutcome::kIterationLimit;
    double u_p = 0.0;  // multiplier of p along the step
    for (;;) {
      const int qc = count_;
      jt_normal(p);
      // (2): primal direction s = J₂d₂, dual direction r = R⁻¹d₁.
      const double d2_norm2 = d_.tail(n_ - qc).squaredNorm();
      const bool has_primal_step = d2_norm2 > kDependence * kDependence * d_.squaredNorm();
      if (has_primal_step) step_.noalias() = J_.rightCols(n_ - qc) * d_.tail(n_ - qc);
      if (qc > 0) {
        r_.head(qc) = d_.head(qc);
        R_.topLeftCorner(qc, qc).triangularView<Eigen::Upper>().solveInPlace(r_.head(qc));
      }
      // Partial step: the first inequality multiplier to reach zero.
      double t1 = kInfinity;
      int k = -1;
      for (int j = equalities; j < qc; ++j) {
        if (r_[j] > 0.0 && u_[j] / r_[j] < t1) {
          t1 = u_[j] / r_[j];
          k = j;
        }
      }
      const double slack = normal_dot(p, x_) - value(p);
      const double t2 = has_primal_step ? std::max(0.0, -slack / d2_norm2) : kInfinity;
      if (!has_primal_step && k < 0) {
        return check_certificate(p) ? ActiveSetOutcome::kInfeasible
                                    : ActiveSetOutcome::kNumericalError;
      }
      const double t = std::min(t1, t2);
      if (has_primal_step) x_.noalias() += t * step_;
      if (qc > 0) u_.head(qc) -= t * r_.head(qc);
      u_p += t;
      if (t2 <= t1) {
        if (!add(p)) return ActiveSetOutcome::kNumericalError;
        u_[count_ - 1] = u_p;
        break;
      }
      u_[k] = 0.0;
      drop(k);
      if (++iterations_ > max_iterations) return ActiveSetOutcome::kIterationLimit;
    }
  }
  // The steps accumulate round-off; (1) on the final working set puts z exactly on it.
  solve_working_set();
  for (int j = equalities; j < count_; ++j) {
    if (u_[j] < 0.0) u_[j] = 0.0;  // round-off of a degenerate side; the check below decides
  }
  if (most_violated(p, violation)) return ActiveSetOutcome::kNumericalError;
  if (!finish(true)) return ActiveSetOutcome::kNumericalError;
  saved_count_ = 0;
  for (int j = equalities; j < count_; ++j) saved_[saved_count_++] = active_[j];
  return ActiveSetOutcome::kSolved;
}

bool DualActiveSet::finish(bool gx_current) {
  const QpProblem& q = *q_;
  product_columns(q.H, n_, x_, hx_.data());  // Hz (Eigen's product here is not the AVX2 clone)
  objective_ = 0.5 * x_.dot(hx_) + q.f.dot(x_);
  // Stationarity Hz + f − Σ uⱼnⱼ = 0.
  res_.setZero();
  for (int j = 0; j < count_; ++j) add_normal(active_[j], u_[j], res_);
  const double scale = std::max({1.0, hx_.cwiseAbs().maxCoeff(), q.f.cwiseAbs().maxCoeff(),
                                 res_.cwiseAbs().maxCoeff()});
  res_ = hx_ + q.f - res_;
  dual_residual_ = res_.cwiseAbs().maxCoeff();
  // Largest violation of any side (absolute), equalities included.
  double worst = 0.0;
  for (int i = 0; i < n_; ++i) {
    if (q.lb.size() != 0 && finite_side(q.lb[i])) worst = std::max(worst, q.lb[i] - x_[i]);
    if (q.ub.size() != 0 && finite_side(q.ub[i])) worst = std::max(worst, x_[i] - q.ub[i]);
  }
  if (m_ > 0 && !gx_current) gx_.head(m_).noalias() = q.G * x_;
  for (int j = 0; j < m_live_; ++j) {  // the free rows after them have no side to violate
    if (finite_side(q.lg[j])) worst = std::max(worst, q.lg[j] - gx_[j]);
    if (finite_side(q.ug[j])) worst = std::max(worst, gx_[j] - q.ug[j]);
  }
  for (int k = 0; k < p_; ++k) worst = std::max(worst, std::abs(q.A.row(k).dot(x_) - q.b[k]));
  primal_residual_ = worst;
  // Every equality must hold, also those left out of the working set as dependent (the
  // inequalities were checked by most_violated()).
  auto holds = [&](Side c) {
    return std::abs(normal_dot(c, x_) - value(c)) <=
           tolerance_ * std::max({1.0, norm(c), std::abs(value(c))});
  };
  for (int k = 0; k < p_; ++k) {
    if (!holds(Side{kEqualityRow, k})) return false;
  }
  for (int j = 0; j < m_live_; ++j) {
    if (is_equality(Side{kRowLower, j}) && !holds(Side{kRowLower, j})) return false;
  }
  for (int i = 0; i < n_ && q.lb.size() != 0; ++i) {
    if (is_equality(Side{kLower, i}) && !holds(Side{kLower, i})) return false;
  }
  return dual_residual_ <= 10.0 * tolerance_ * scale;
}

void DualActiveSet::multipliers(Eigen::VectorXd& dual_bounds, Eigen::VectorXd& dual_rows,
                                Eigen::VectorXd& dual_eq) const {
  dual_bounds.setZero(n_);
  dual_rows.setZero(m_);
  dual_eq.setZero(p_);
  for (int j = 0; j < count_; ++j) {
    const Side c = active_[j];
    switch (c.kind) {
      case kLower:
        dual_bounds[c.index] = -u_[j];
        break;
      case kUpper:
        dual_bounds[c.index] = u_[j];
        break;
      case kRowLower:
        dual_rows[c.index] = -u_[j];
        break;
      case kRowUpper:
        dual_rows[c.index] = u_[j];
        break;
      default:
        dual_eq[c.index] = -u_[j];
    }
  }
}

void DualActiveSet::set_working_set(const QpResult& result, double threshold) {
  saved_count_ = 0;
  for (int i = 0; i < n_ && i < result.dual_bounds.size() && saved_count_ < n_; ++i) {
    const double w = result.dual_bounds[i];
    if (std::abs(w) > threshold) saved_[saved_count_++] = Side{w > 0.0 ? kUpper : kLower, i};
  }
  for (int j = 0; j < m_ && j < result.dual_rows.size() && saved_count_ < n_; ++j) {
    const double w = result.dual_rows[j];
    if (std::abs(w) > threshold) saved_[saved_count_++] = Side{w > 0.0 ? kRowUpper : kRowLower, j};
  }
}

void DualActiveSet::renumber_rows(const int* new_row_of_old, int old_rows) {
  int kept = 0;
  for (int k = 0; k < saved_count_; ++k) {
    Side c = saved_[k];
    if (c.kind == kRowLower || c.kind == kRowUpper) {
      c.index = c.index < old_rows ? new_row_of_old[c.index] : -1;
      if (c.index < 0) continue;
    }
    saved_[kept++] = c;
  }
  saved_count_ = kept;
}

}  // namespace ridgeline::qp
