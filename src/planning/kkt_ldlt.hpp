// The sparse symmetric indefinite factorization behind the planner's Ipopt solves.
//
// Every Ipopt iteration solves its KKT system [W + Σ_x, Jᵀ; J, −D] (with the slacks' rows)
// at least once. Debian's Ipopt factors it with MUMPS, whose set-up per factorization costs
// more than the arithmetic on systems of a few thousand rows like ours (3 UAVs × 100
// waypoints: 3 882 rows, ~20 000 entries). SparseLdlt factors the same matrix as P A Pᵀ = L D Lᵀ
// with 1×1 pivots in a fixed order chosen once per sparsity pattern (kkt_ldlt.cpp):
//  - rows with at most one off-diagonal entry first (Ipopt's slack rows: their pivot is the
//    slack's barrier term Σ_s > 0, after which each constraint row carries −1/Σ_s < 0),
//  - then the constraint rows (pivot −1/Σ_s − δ_d), which condenses the system onto the
//    variables: W + Σ_x + Jᵀ Σ_s J,
//  - then the variables in the approximate minimum degree order (Eigen's AMD) of that
//    condensed pattern. The condensed matrix is positive definite exactly when the KKT matrix
//    has the inertia Ipopt asks for, so its pivots are a Cholesky factorization's: stable in
//    any order, however large Σ_s grows near the solution.
// By Sylvester's law of inertia the number of negative pivots is the number of negative
// eigenvalues, which is what Ipopt's inertia correction needs. A zero or non-finite pivot is
// reported as singular, and Ipopt then regularizes (δ_x, δ_c) and factors again, as it does
// for any solver.
//
// IpoptKktSolver hands SparseLdlt to Ipopt as its "ma27" solver through the HSL loader that
// Debian's Ipopt is built with (LSL_setMA27): the MA27 calling convention (analyse, factor,
// solve) with the factorization kept on our side and a handle in MA27's work arrays.
#pragma once

#include <Eigen/SparseCore>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace ridgeline::planning {

class SparseLdlt {
 public:
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  SparseLdlt();
  ~SparseLdlt();
  SparseLdlt(const SparseLdlt&) = delete;
  SparseLdlt& operator=(const SparseLdlt&) = delete;

  /// The pattern of a symmetric n × n matrix as triplets (0-based; each off-diagonal entry
  /// given once in either triangle; repeated entries are summed). Chooses the pivot order
  /// and the pattern of L.
  void analyze(int n, std::span<const int> rows, std::span<const int> cols);

  enum class Status { kOk, kSingular };
  /// Factors the matrix with these values (in the order of analyze's triplets).
  Status factorize(std::span<const double> values);
  /// Negative pivots of the last successful factorization (= negative eigenvalues).
  int negative_pivots() const { return negative_pivots_; }
  /// Solves A x = b in place (after a successful factorize), with up to 3 steps of iterative
  /// refinement until ‖b − A x‖∞ ≤ 1e-15·(‖A‖∞‖x‖∞ + ‖b‖∞).
  void solve(std::span<double> rhs) const;

  int size() const { return n_; }

 private:
  struct Factor;  // Eigen's SimplicialLDLT on the permuted pattern
  int n_ = 0;
  std::vector<int> order_;  ///< order_[k]: the original row pivoted k-th
  std::vector<int> slot_;   ///< triplet → index into the permuted lower CSC's values
  Matrix permuted_;         ///< lower triangle of P A Pᵀ
  std::unique_ptr<Factor> factor_;
  int negative_pivots_ = 0;
  double a_norm_ = 0.0;  ///< ‖A‖∞ of the last factorized values
  mutable std::vector<double> work_;
  static constexpr int kMaxRefinementSteps = 3;
  static constexpr double kRefinementTolerance = 1e-15;
};

/// While an IpoptKktSolver exists, Ipopt solves started on this thread with the options from
/// ipopt_options() factor their KKT systems with SparseLdlt. The factorizations Ipopt makes are
/// owned by the IpoptKktSolver and freed with it, so keep it alive for the whole
/// OptimizeTNLP call. Thread-safe: each thread has its own registry.
class IpoptKktSolver {
 public:
  IpoptKktSolver();
  ~IpoptKktSolver();
  IpoptKktSolver(const IpoptKktSolver&) = delete;
  IpoptKktSolver& operator=(const IpoptKktSolver&) = delete;

  /// The Ipopt options that select this solver: linear_solver ma27 (our stand-in), no MC19
  /// scaling (an HSL routine we do not provide).
  static std::vector<std::pair<std::string, std::string>> ipopt_options();
  /// Factorizations made so far on this thread's Ipopt solves (for tests).
  static long factorizations();

 private:
  std::size_t first_handle_ = 0;
};

}  // namespace ridgeline::planning
