#include "planning/kkt_ldlt.hpp"

#include <coin/HSLLoader.h>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <mutex>
#include <stdexcept>

namespace ridgeline::planning {

struct SparseLdlt::Factor {
  // The order is ours (already applied to `permuted_`), so Eigen keeps it as it is.
  Eigen::SimplicialLDLT<Matrix, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt;
};

namespace {

using Pattern = SparseLdlt::Matrix;

// Approximate minimum degree order of a symmetric pattern (both triangles): Eigen's AMD, which
// needs the diagonal present (without it, it returns the identity) and returns P⁻¹, whose
// indices()[k] is the row pivoted k-th.
std::vector<int> amd_order(Pattern pattern) {
  for (int i = 0; i < pattern.cols(); ++i) pattern.coeffRef(i, i) = 1.0;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
  Eigen::AMDOrdering<int>()(pattern, inverse);
  return {inverse.indices().data(), inverse.indices().data() + pattern.cols()};
}

// The pivot order, in three groups (see the header):
//  1. leaves, rows with at most one off-diagonal entry: Ipopt's slack rows, pivot Σ_s > 0;
//  2. their neighbours: the constraint rows, pivot −1/Σ_s − δ_d < 0 once the slack is out;
//  3. the rest (the variables), in the AMD order of what is left after groups 1–2 are
//     eliminated: the condensed matrix W + Σ_x + Jᵀ Σ_s J, positive definite exactly when the
//     KKT matrix has the inertia Ipopt wants, so that its pivots are those of a Cholesky
//     factorization — stable in any order, however large Σ_s grows near the solution.
// A pattern not shaped like Ipopt's still gets a valid order; only the stability argument is
// Ipopt's.
std::vector<int> pivot_order(const Pattern& pattern) {
  const int n = static_cast<int>(pattern.cols());
  enum Group : char { kLeaf, kRow, kRest };
  std::vector<Group> group(static_cast<std::size_t>(n), kRest);
  for (int i = 0; i < n; ++i)
    if (pattern.col(i).nonZeros() <= 1) group[static_cast<std::size_t>(i)] = kLeaf;
  for (int i = 0; i < n; ++i) {
    if (group[static_cast<std::size_t>(i)] != kLeaf) continue;
    for (Pattern::InnerIterator it(pattern, i); it; ++it)
      if (group[static_cast<std::size_t>(it.row())] == kRest)
        group[static_cast<std::size_t>(it.row())] = kRow;
  }
  std::vector<int> order;
  order.reserve(static_cast<std::size_t>(n));
  for (Group g : {kLeaf, kRow})
    for (int i = 0; i < n; ++i)
      if (group[static_cast<std::size_t>(i)] == g) order.push_back(i);
  // The pattern of the rest after eliminating the rows: its own entries plus, for every
  // eliminated row, a clique on the variables it touches (Jᵀ J).
  std::vector<int> local(static_cast<std::size_t>(n), -1);
  std::vector<int> rest;
  for (int i = 0; i < n; ++i)
    if (group[static_cast<std::size_t>(i)] == kRest) {
      local[static_cast<std::size_t>(i)] = static_cast<int>(rest.size());
      rest.push_back(i);
    }
  std::vector<Eigen::Triplet<double, int>> t;
  std::vector<int> touched;
  for (int i = 0; i < n; ++i) {
    const int li = local[static_cast<std::size_t>(i)];
    if (group[static_cast<std::size_t>(i)] == kLeaf) continue;
    touched.clear();
    for (Pattern::InnerIterator it(pattern, i); it; ++it) {
      const int lj = local[static_cast<std::size_t>(it.row())];
      if (lj < 0) continue;
      if (li >= 0) {
        t.emplace_back(lj, li, 1.0);
      } else {
        touched.push_back(lj);
      }
    }
    for (int a : touched)
      for (int b : touched)
        if (a != b) t.emplace_back(a, b, 1.0);
  }
  const int m = static_cast<int>(rest.size());
  Pattern condensed(m, m);
  condensed.setFromTriplets(t.begin(), t.end());
  for (int k : amd_order(std::move(condensed))) order.push_back(rest[static_cast<std::size_t>(k)]);
  return order;
}

}  // namespace

SparseLdlt::SparseLdlt() : factor_(std::make_unique<Factor>()) {}
SparseLdlt::~SparseLdlt() = default;

void SparseLdlt::analyze(int n, std::span<const int> rows, std::span<const int> cols) {
  if (n < 0 || rows.size() != cols.size()) throw std::invalid_argument("SparseLdlt: bad pattern");
  n_ = n;
  const std::size_t nz = rows.size();
  for (std::size_t k = 0; k < nz; ++k)
    if (rows[k] < 0 || rows[k] >= n || cols[k] < 0 || cols[k] >= n)
      throw std::invalid_argument("SparseLdlt: triplet index out of range");

  // The symmetric pattern (both triangles, no diagonal) for the ordering and the degrees.
  Pattern pattern(n, n);
  {
    std::vector<Eigen::Triplet<double, int>> t;
    t.reserve(2 * nz);
    for (std::size_t k = 0; k < nz; ++k)
      if (rows[k] != cols[k]) {
        t.emplace_back(rows[k], cols[k], 1.0);
        t.emplace_back(cols[k], rows[k], 1.0);
      }
    pattern.setFromTriplets(t.begin(), t.end());
  }
  order_ = pivot_order(pattern);
  std::vector<int> position(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) position[static_cast<std::size_t>(order_[k])] = k;

  // The lower triangle of P A Pᵀ in compressed columns, every diagonal present (Eigen's LDLᵀ
  // reads it), and each triplet's slot in it.
  std::vector<std::pair<int, int>> entries;  // (column, row), row ≥ column
  entries.reserve(nz + static_cast<std::size_t>(n));
  auto permuted_entry = [&](int r, int c) {
    const int pr = position[static_cast<std::size_t>(r)];
    const int pc = position[static_cast<std::size_t>(c)];
    return pr >= pc ? std::pair{pc, pr} : std::pair{pr, pc};
  };
  for (std::size_t k = 0; k < nz; ++k) entries.push_back(permuted_entry(rows[k], cols[k]));
  for (int i = 0; i < n; ++i) entries.emplace_back(i, i);
  std::sort(entries.begin(), entries.end());
  entries.erase(std::unique(entries.begin(), entries.end()), entries.end());
  permuted_.resize(n, n);
  permuted_.resizeNonZeros(static_cast<Eigen::Index>(entries.size()));
  int* outer = permuted_.outerIndexPtr();
  int* inner = permuted_.innerIndexPtr();
  std::fill(outer, outer + n + 1, 0);
  for (std::size_t e = 0; e < entries.size(); ++e) {
    ++outer[entries[e].first + 1];
    inner[e] = entries[e].second;
  }
  for (int c = 0; c < n; ++c) outer[c + 1] += outer[c];
  slot_.resize(nz);
  for (std::size_t k = 0; k < nz; ++k) {
    const auto key = permuted_entry(rows[k], cols[k]);
    slot_[k] =
        static_cast<int>(std::lower_bound(entries.begin(), entries.end(), key) - entries.begin());
  }
  std::fill(permuted_.valuePtr(), permuted_.valuePtr() + entries.size(), 0.0);
  factor_->ldlt.analyzePattern(permuted_);
  work_.assign(3 * static_cast<std::size_t>(n), 0.0);
  negative_pivots_ = 0;
}

SparseLdlt::Status SparseLdlt::factorize(std::span<const double> values) {
  if (values.size() != slot_.size()) throw std::invalid_argument("SparseLdlt: value count");
  double* v = permuted_.valuePtr();
  std::fill(v, v + permuted_.nonZeros(), 0.0);
  for (std::size_t k = 0; k < slot_.size(); ++k) v[slot_[k]] += values[k];
  factor_->ldlt.factorize(permuted_);
  negative_pivots_ = 0;
  if (factor_->ldlt.info() != Eigen::Success) return Status::kSingular;
  const auto d = factor_->ldlt.vectorD();
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    // A subnormal pivot is as good as zero: its reciprocal overflows.
    if (!std::isfinite(d[i]) || std::abs(d[i]) < 1e-300) return Status::kSingular;
    if (d[i] < 0.0) ++negative_pivots_;
  }
  // ‖A‖∞ (largest row sum of |a_ij|) for the refinement's stopping test, in solve's first
  // work slot (the lower triangle holds each off-diagonal entry once: count it in both rows).
  Eigen::Map<Eigen::VectorXd> row_sums(work_.data(), n_);
  row_sums.setZero();
  for (int c = 0; c < n_; ++c)
    for (Matrix::InnerIterator it(permuted_, c); it; ++it) {
      row_sums[it.row()] += std::abs(it.value());
      if (it.row() != c) row_sums[c] += std::abs(it.value());
    }
  a_norm_ = n_ > 0 ? row_sums.maxCoeff() : 0.0;
  return Status::kOk;
}

void SparseLdlt::solve(std::span<double> rhs) const {
  assert(static_cast<int>(rhs.size()) == n_);
  // In the pivot order throughout: b, the solution x and the residual r = b − P A Pᵀ x.
  Eigen::Map<Eigen::VectorXd> x(work_.data(), n_);
  Eigen::Map<Eigen::VectorXd> b(work_.data() + n_, n_);
  Eigen::Map<Eigen::VectorXd> r(work_.data() + 2 * static_cast<std::ptrdiff_t>(n_), n_);
  for (int k = 0; k < n_; ++k) b[k] = rhs[static_cast<std::size_t>(order_[k])];
  auto apply_inverse = [&](Eigen::Map<Eigen::VectorXd>& v) {
    factor_->ldlt.matrixL().solveInPlace(v);
    v = v.cwiseQuotient(factor_->ldlt.vectorD());
    factor_->ldlt.matrixU().solveInPlace(v);
  };
  x = b;
  apply_inverse(x);
  // Iterative refinement: the condensed pivots can lose digits when the barrier terms span
  // many orders of magnitude near a solution; a few residual corrections give back a
  // backward-stable solve (what MUMPS's pivoting gives Ipopt), at the cost of a sparse
  // product and a solve each.
  const double b_norm = b.lpNorm<Eigen::Infinity>();
  for (int step = 0; step < kMaxRefinementSteps; ++step) {
    r = b - permuted_.selfadjointView<Eigen::Lower>() * x;
    const double bound = kRefinementTolerance * (a_norm_ * x.lpNorm<Eigen::Infinity>() + b_norm);
    if (!(r.lpNorm<Eigen::Infinity>() > bound)) break;
    apply_inverse(r);
    x += r;
  }
  for (int k = 0; k < n_; ++k) rhs[static_cast<std::size_t>(order_[k])] = x[k];
}

// ----- Ipopt's MA27 calling convention ---------------------------------------------------

namespace {

// The factorizations of this thread's Ipopt solves; handle h is registry[h − 1].
struct Registry {
  std::vector<std::unique_ptr<SparseLdlt>> ldlt;
  int active = 0;  // live IpoptKktSolver objects
  long factorizations = 0;
};
thread_local Registry registry;

SparseLdlt* from_handle(ipfint handle) {
  if (handle < 1 || static_cast<std::size_t>(handle) > registry.ldlt.size()) return nullptr;
  return registry.ldlt[static_cast<std::size_t>(handle - 1)].get();
}

// MA27's INFO(1) (iflag) values that Ipopt reads.
constexpr ipfint kMa27Ok = 0;
constexpr ipfint kMa27BadInput = -1;
constexpr ipfint kMa27Singular = 3;

void ma27id(ipfint* icntl, double* cntl) {
  std::fill(icntl, icntl + 30, 0);
  std::fill(cntl, cntl + 5, 0.0);
}

// Analysis: chooses the order; the handle goes into IKEEP(1), which Ipopt keeps for ma27bd.
void ma27ad(ipfint* n, ipfint* nz, const ipfint* irn, const ipfint* icn, ipfint* /*iw*/,
            ipfint* /*liw*/, ipfint* ikeep, ipfint* /*iw1*/, ipfint* nsteps, ipfint* iflag,
            ipfint* /*icntl*/, double* /*cntl*/, ipfint* info, double* ops) {
  std::fill(info, info + 20, 0);
  *ops = 0.0;
  *nsteps = 1;
  *iflag = 0;
  if (registry.active == 0 || *n < 1 || *nz < 0) {
    info[0] = kMa27BadInput;
    return;
  }
  std::vector<int> rows(static_cast<std::size_t>(*nz));
  std::vector<int> cols(static_cast<std::size_t>(*nz));
  for (ipfint k = 0; k < *nz; ++k) {
    rows[static_cast<std::size_t>(k)] = irn[k] - 1;  // Fortran's 1-based indices
    cols[static_cast<std::size_t>(k)] = icn[k] - 1;
  }
  auto ldlt = std::make_unique<SparseLdlt>();
  try {
    ldlt->analyze(*n, rows, cols);
  } catch (const std::invalid_argument&) {
    info[0] = kMa27BadInput;
    return;
  }
  registry.ldlt.push_back(std::move(ldlt));
  ikeep[0] = static_cast<ipfint>(registry.ldlt.size());
  // Work-array sizes Ipopt allocates for ma27bd/ma27cd: the factor lives with us, the arrays
  // carry only the handle.
  info[4] = 1;  // LA
  info[5] = 2;  // LIW
}

// Factorization of A(1:NZ); INFO(15) = negative eigenvalues; the handle goes into IW(1).
void ma27bd(ipfint* /*n*/, ipfint* nz, const ipfint* /*irn*/, const ipfint* /*icn*/, double* a,
            ipfint* /*la*/, ipfint* iw, ipfint* /*liw*/, ipfint* ikeep, ipfint* nsteps,
            ipfint* maxfrt, ipfint* /*iw1*/, ipfint* /*icntl*/, double* /*cntl*/, ipfint* info) {
  std::fill(info, info + 20, 0);
  *nsteps = 1;
  *maxfrt = 1;
  SparseLdlt* ldlt = from_handle(ikeep[0]);
  if (ldlt == nullptr) {
    info[0] = kMa27BadInput;
    return;
  }
  ++registry.factorizations;
  const auto status = ldlt->factorize(std::span<const double>(a, static_cast<std::size_t>(*nz)));
  iw[0] = ikeep[0];
  if (status == SparseLdlt::Status::kSingular) {
    info[0] = kMa27Singular;
    return;
  }
  info[0] = kMa27Ok;
  info[14] = ldlt->negative_pivots();
}

void ma27cd(ipfint* n, double* /*a*/, ipfint* /*la*/, ipfint* iw, ipfint* /*liw*/, double* /*w*/,
            ipfint* /*maxfrt*/, double* rhs, ipfint* /*iw1*/, ipfint* /*nsteps*/, ipfint* /*icntl*/,
            double* /*cntl*/) {
  const SparseLdlt* ldlt = from_handle(iw[0]);
  if (ldlt == nullptr || ldlt->size() != *n) {
    // Cannot happen after a successful ma27bd; a NaN solution makes Ipopt stop rather than
    // step on garbage.
    std::fill(rhs, rhs + *n, std::nan(""));
    return;
  }
  ldlt->solve(std::span<double>(rhs, static_cast<std::size_t>(*n)));
}

}  // namespace

IpoptKktSolver::IpoptKktSolver() : first_handle_(registry.ldlt.size()) {
  // Ipopt's loader keeps the entry points in globals: set them once, not from every thread.
  static std::once_flag registered;
  std::call_once(registered, [] { LSL_setMA27(&ma27ad, &ma27bd, &ma27cd, &ma27id); });
  ++registry.active;
}

IpoptKktSolver::~IpoptKktSolver() {
  --registry.active;
  registry.ldlt.resize(first_handle_);
}

std::vector<std::pair<std::string, std::string>> IpoptKktSolver::ipopt_options() {
  return {{"linear_solver", "ma27"}, {"linear_system_scaling", "none"}};
}

long IpoptKktSolver::factorizations() { return registry.factorizations; }

}  // namespace ridgeline::planning
