// Plant-agnostic incremental (velocity-form) model predictive controller (DESIGN §3,
// paper eq. 5–11).
//
// Plant, possibly time-varying along the horizon (step j maps s_j to s_{j+1}):
//
//   s_{j+1} = A_j s_j + B_j u_j + E_j d_j (+ affine terms),   y_j = C s_j
//
// Incremental form (eq. 6–7): with Δs_j = s_j − s_{j−1}, Δu_j = u_j − u_{j−1},
// Δd_j = d_j − d_{j−1} and the augmented state ξ_j = [Δs_j; y_j],
//
//   ξ_{j+1} = [A_j 0; C·A_j I] ξ_j + [B_j; C·B_j] Δu_j + [w_j; C·w_j],
//   w_j     = E_j Δd_j + o_j,                                               (eq. 7)
//
// where o_j is an optional known offset (for a time-varying plant the exact increment also
// holds (A_j − A_{j−1}) s_{j−1} + …; a caller who knows such terms along a nominal trajectory
// passes them in o_j, otherwise they are neglected — the usual LTV velocity-form
// approximation). For an LTI plant without offsets eq. 7 is exact.
//
// Measured disturbance (wind). A disturbance enters the incremental form only through its
// increment Δd_j: a constant d changes every s_{j+1} − s_j by the same E·d, which is already
// contained in the measured Δs_k. So a constant disturbance needs no model at all (this, plus
// y_k in ξ, is the integral action of the incremental form), and feed-forward of a measured
// d acts on its changes: Δd_k = d_k − d_{k−1} at the current step and the forecast increments
// later in the horizon (zero for a "held" measurement).
//
// Stacking over the prediction horizon Np with moves only in the first Nc steps
// (Δu_j = 0 for j ≥ Nc, eq. 8–9):
//
//   Y = F ξ_k + Φ ΔU + Y_w,    Y = [y_{k+1}; …; y_{k+Np}],  ΔU = [Δu_k; …; Δu_{k+Nc−1}]
//
// with F = [C̃ Ã_0; C̃ Ã_1 Ã_0; …], Φ(j, i) = C̃ Ã_j ⋯ Ã_{i+1} B̃_i (j ≥ i), C̃ = [0 I], and
// Y_w the response to the known terms w_j. Cost (eq. 10) plus slack penalty:
//
//   J = (R − Y)ᵀ Q̄ (R − Y) + ΔUᵀ R̄ ΔU + Σ_g (ρ₁ σ_g + ρ₂ σ_g²)
//
// Q̄ = diag(Q, …, Q, Q_N), R̄ = diag(R, …, R), Q, Q_N, R diagonal. Constraints (eq. 11):
//   hard   Δu_min,i ≤ Δu_{k+i} ≤ Δu_max,i              (box bounds of the QP)
//          u_min,i ≤ u_{k−1} + Σ_{l≤i} Δu_{k+l} ≤ u_max,i  (Nc·n_u general rows)
//          y_min,j ≤ y_{k+j+1} ≤ y_max,j                (Np·n_y rows, optional)
//   soft   aᵀ y_{k+j+1} + σ_g ≥ b,  σ_g ≥ 0             (one row per call of add_soft_row)
// The slack σ_g is shared by all soft rows of group g (a group is a kind of constraint, e.g.
// "threats"), which keeps the QP small; its exact-penalty weight ρ₁ makes σ = 0 whenever the
// rows are satisfiable (provided ρ₁ exceeds the sum of the group's row multipliers, so scale it
// with the tracking cost), and σ_g reports the largest violation the solution accepts in that
// group. With soft rows only (no hard output rows) and consistent input/move limits the QP
// is always feasible.
//
// QP in z = [ΔU; σ] (n = Nc·n_u + slack groups): H = 2·blkdiag(ΦᵀQ̄Φ + R̄, ρ₂ I),
// f = [−2 ΦᵀQ̄(R − Y_free); ρ₁ 1], Y_free = F ξ_k + Y_w the free response (moves zero).
// The QP orders ΔU by input, then move (z_{c·Nc + i} = Δu_{k+i,c}), as Φ's columns: H, f and
// the rows need no reordering, and inputs that no output couples (the UAV's climb against its
// speed and turn) make H block-diagonal in contiguous blocks, whose Cholesky factor keeps the
// zeros. IncrementalMpcResult::moves is ordered by move, then input.
//
// Condensing exploits the structure instead of multiplying dense stacked matrices:
//  - Φ is built block by block by one forward pass over the stage matrices: Γ_j = ∂Δs_{j+1}/∂ΔU
//    obeys Γ_j = A_j Γ_{j−1} (+ B_j in the columns of move j), and the output rows are
//    Φ_j = Φ_{j−1} + C Γ_j. Only the exact nonzeros of A_j and C are visited; the columns of
//    the moves not started by step j (Φ is block lower-triangular) are summed as exact zeros
//    inside a row's span (one loop a row, no per-move branches). The free response is the
//    same pass on one vector, so F and Y_w are never formed.
//  - The reach of a state or output (the inputs whose moves change it, from the nonzero
//    patterns of B, A and C) bounds the columns a row of Γ or Φ can have: for the UAV, x and y
//    are reached by the speed and turn commands, z by the climb command only. Row updates and
//    the cost sums skip the other inputs' columns; a soft row aᵀΦ_j sums whole columns of Φ_j,
//    whose entries outside the reaches are exact zeros (see assemble_soft_rows).
//  - Q̄ is diagonal, so ΦᵀQ̄Φ = Σ_rows q_r φ_r φ_rᵀ; the sum runs over each row's span (from
//    its first to its last reached input's columns; see build_prediction), four rows at a time.
//  - What did not change since the last step is kept: a row of Γ_j whose row of A_j and B_j
//    and whose source rows of Γ_{j−1} are unchanged keeps its values (A's compared as bits),
//    a row of Φ_j likewise with C, a group's block of H when none of its rows changed, and a
//    row's range over the move box (see forward_pass). For the UAV only the x and y rows are
//    computed each step; rows that change at every step alternate between two rows of Γ.
//  - Which rows a pass computes, from which rows and coefficients, is decided row by row from
//    what changed; while that is the same as at the last pass (the tracker's steady state: the
//    x and y rows of every step), the pass replays the last one's row updates as recorded.
//  - The input-limit rows, the slack terms and the QP's layout are written once at
//    construction.
//  - Soft rows that no move within the move limits can violate are left out of the QP (they
//    cannot change its solution; see assemble_soft_rows), and the QP's hot start follows the
//    rows it keeps by (group, source, step) as they come, go and shift.
// All matrices are preallocated at construction; after the first solve a step allocates
// nothing unless the soft rows it carries need more blocks of kSoftRowBlock rows than any
// step's before: the QP holds the soft rows in such blocks, padded with rows whose sides are
// both infinite, and keeps the largest size it has needed, so its size — and the solver's
// warm start — survives the changes of the soft rows from step to step.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string_view>
#include <vector>

#include "core/simd_clones.hpp"
#include "core/types.hpp"
#include "qp/qp_solver.hpp"

namespace ridgeline::mpc {

/// Sizes of the plant and of the soft-constraint storage; fixed for the controller's life.
struct IncrementalMpcDims {
  int state_dim = 0;          ///< n_s ≥ 1
  int input_dim = 0;          ///< 1 ≤ n_u ≤ 64
  int output_dim = 0;         ///< n_y ≥ 1
  int disturbance_dim = 0;    ///< n_d ≥ 0 (0: no measured disturbance)
  int soft_row_capacity = 0;  ///< largest number of soft rows in one step, ≥ 0
  int slack_groups = 0;       ///< number of slack variables σ_g, ≥ 0 (≥ 1 if soft rows exist)
};

/// Tuning with documented defaults. Weights are the diagonals of Q, Q_N and R (eq. 10).
struct IncrementalMpcOptions {
  int prediction_horizon = 40;  ///< Np ≥ 1
  int control_horizon = 10;     ///< Nc, 1 ≤ Nc ≤ Np
  VecX output_weight;           ///< diag Q, n_y entries ≥ 0
  VecX terminal_output_weight;  ///< diag Q_N at j = Np, n_y entries ≥ 0; empty: Q
  VecX move_weight;             ///< diag R, n_u entries > 0 (keeps H positive definite)
  /// Constant limits of eq. 11 (n_u or n_y entries; empty: unbounded). They initialize the
  /// per-step limits of IncrementalMpcData, which a caller may overwrite step by step.
  VecX input_min, input_max;            ///< u_min, u_max
  VecX move_min, move_max;              ///< Δu_min, Δu_max
  VecX output_min, output_max;          ///< y_min, y_max (used when hard_output_limits)
  bool hard_output_limits = false;      ///< add the rows y_min ≤ y ≤ y_max of eq. 11
  double slack_linear_weight = 1e4;     ///< ρ₁ > 0, per unit of slack (exact penalty)
  double slack_quadratic_weight = 1e2;  ///< ρ₂ > 0, per unit² of slack
  /// Leave out of the QP the soft rows no move within the move limits can violate (see
  /// assemble_soft_rows): the solution is the same, the QP smaller. Off only to inspect every
  /// row in qp_problem().
  bool drop_redundant_soft_rows = true;
  /// Time the condensing and the soft rows (IncrementalMpcResult::condensing_time_us,
  /// soft_rows_time_us): four readings of the steady clock a step, about 0.1 µs. Off, both are
  /// NaN.
  bool time_parts = true;
  qp::QpSettings qp_settings;
};

/// The data of one step, preallocated by the controller and filled by the caller before
/// solve(). Column j of a horizon matrix belongs to prediction step j (0-based): for the
/// plant, the transition s_{k+j} → s_{k+j+1}; for outputs and references, y_{k+j+1}; for
/// input and move limits, move j (u_{k+j}, Δu_{k+j}).
struct IncrementalMpcData {
  std::vector<MatX> A;  ///< Np matrices n_s×n_s (A_j)
  std::vector<MatX> B;  ///< Np matrices n_s×n_u (B_j)
  std::vector<MatX> E;  ///< Np matrices n_s×n_d (E_j)
  MatX C;               ///< n_y×n_s

  VecX delta_state;        ///< Δs_k = s_k − s_{k−1} (measured increment)
  VecX output;             ///< y_k (measured)
  VecX state;              ///< s_k, only to report predicted absolute states
  VecX previous_input;     ///< u_{k−1}, the input applied last
  MatX disturbance_delta;  ///< n_d×Np, Δd_{k+j}
  MatX state_offset;       ///< n_s×Np, o_j (zero unless the caller knows affine terms)
  MatX reference;          ///< n_y×Np, r_{k+j+1}

  MatX input_min, input_max;    ///< n_u×Nc, per move (±infinity allowed)
  MatX move_min, move_max;      ///< n_u×Nc, per move (±infinity allowed)
  MatX output_min, output_max;  ///< n_y×Np, used when hard_output_limits

  /// Copies one (A, B, E) into every step of the horizon and sets C. E may be empty if
  /// n_d = 0.
  void set_time_invariant(const MatX& A_, const MatX& B_, const MatX& C_, const MatX& E_);

  /// Adds the soft row aᵀ y_{k+step+1} + σ_group ≥ bound. Returns false (and adds nothing) if
  /// the capacity is full or step/group/source is out of range; the caller reports that.
  /// `source` (≥ 0) tells the rows of one group apart (e.g. which threat): a row keeps its
  /// (group, source, step) from one solve to the next, and the QP's hot start follows the
  /// rows by it. Rows added in increasing (group, source, step) order are followed; in any
  /// other order the hot start reads the rows by their position.
  bool add_soft_row(int step, const Eigen::Ref<const VecX>& a, double bound, int group,
                    int source = 0);
  /// The same with a's n_y coefficients at `a` (a tracker's fixed-size vector).
  bool add_soft_row(int step, const double* a, double bound, int group, int source);
  void clear_soft_rows() { soft_row_count = 0; }

  int soft_row_count = 0;
  std::vector<int> soft_step;    ///< capacity entries
  std::vector<int> soft_group;   ///< capacity entries
  std::vector<int> soft_source;  ///< capacity entries
  MatX soft_normal;              ///< n_y×capacity
  VecX soft_bound;               ///< capacity
};

// Inline: a tracker adds a hundred rows or more a step.
inline bool IncrementalMpcData::add_soft_row(int step, const Eigen::Ref<const VecX>& a,
                                             double bound, int group, int source) {
  if (a.size() != soft_normal.rows()) return false;
  return add_soft_row(step, a.data(), bound, group, source);
}

inline bool IncrementalMpcData::add_soft_row(int step, const double* a, double bound, int group,
                                             int source) {
  const int capacity = static_cast<int>(soft_step.size());
  if (soft_row_count >= capacity || step < 0 || step >= reference.cols() || group < 0 ||
      source < 0) {
    return false;
  }
  soft_step[soft_row_count] = step;
  soft_group[soft_row_count] = group;
  soft_source[soft_row_count] = source;
  const Eigen::Index n = soft_normal.rows();
  double* column = soft_normal.data() + soft_row_count * n;
  if (n == 3) {  // a position's three outputs, written out (GCC makes the loop a memcpy call)
    column[0] = a[0];
    column[1] = a[1];
    column[2] = a[2];
  } else {
    for (Eigen::Index k = 0; k < n; ++k) column[k] = a[k];
  }
  soft_bound[soft_row_count] = bound;
  ++soft_row_count;
  return true;
}

/// Outcome of one step. Unless the QP was solved, the moves are zero and the predictions
/// are the free response (inputs held), i.e. the plan a caller falls back to.
struct IncrementalMpcResult {
  qp::QpStatus qp_status = qp::QpStatus::kInvalidInput;
  /// Empty when the data were consistent; otherwise the name of the offending field
  /// (e.g. "A[3]") and the QP was not attempted.
  std::string_view invalid_field;
  VecX first_move;         ///< Δu_k
  VecX first_input;        ///< u_k = u_{k−1} + Δu_k (the QP's, before any clamping)
  VecX moves;              ///< ΔU, Nc·n_u, by move then input (Δu_k first)
  MatX predicted_outputs;  ///< n_y×Np, y_{k+j+1} under ΔU
  MatX predicted_states;   ///< n_s×Np, s_k + Σ Δs under ΔU
  VecX slack;              ///< σ_g per group
  double max_slack = 0.0;  ///< max_g σ_g
  double cost = 0.0;       ///< J of eq. 10 plus the slack penalty, at the solution
  int qp_iterations = 0;
  /// The soft rows the QP carried: those added, less the ones no move within the move limits
  /// can violate (see assemble_soft_rows), which cannot change the solution.
  int soft_rows_in_qp = 0;
  /// The rows of Γ and Φ the last build_prediction() (solve()'s own, or a caller's) computed,
  /// of (n_s + n_y)·Np: the others did not change since the build before and kept their
  /// values (see build_prediction).
  int prediction_rows_computed = 0;
  /// Whether that build replayed the row updates of the build before it (what decided them
  /// unchanged; see build_prediction) instead of deciding each row.
  bool prediction_replayed = false;
  double qp_time_us = 0.0;          ///< the QP solve (QpResult::solve_time_us)
  double condensing_time_us = 0.0;  ///< Φ, the free response, H and f (wall clock; NaN untimed)
  double soft_rows_time_us = 0.0;   ///< the soft rows written into the QP (wall clock; NaN untimed)

  bool solved() const { return qp_status == qp::QpStatus::kSolved; }
};

class IncrementalMpc {
 public:
  /// Throws ridgeline::InputError naming the option or dimension that is inconsistent.
  IncrementalMpc(const IncrementalMpcDims& dims, const IncrementalMpcOptions& options);

  const IncrementalMpcDims& dims() const { return dims_; }
  const IncrementalMpcOptions& options() const { return options_; }
  int num_variables() const { return nz_; }
  int num_rows() const { return static_cast<int>(qp_.G.rows()); }

  /// The step's data, to be filled before solve(). Sizes are set here; keep them.
  IncrementalMpcData& data() { return data_; }
  const IncrementalMpcData& data() const { return data_; }

  /// Builds Φ and the free response from data() (eq. 8–9). solve() calls it.
  void build_prediction();
  /// Builds and solves the QP, returns the result (valid until the next solve).
  const IncrementalMpcResult& solve();
  /// Forgets the warm start.
  void reset() { solver_.reset(); }

  using RowMatX = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  /// The last build_prediction()'s prediction Y = Y_free + Φ ΔU: Φ is (Np·n_y)×(Nc·n_u) with
  /// its columns ordered by input, then move (column c·Nc + i belongs to Δu_{k+i,c}, as the
  /// QP's variables), and Y_free = F ξ_k + Y_w the outputs predicted with
  /// every move zero (inputs held).
  const RowMatX& Phi() const { return Phi_; }
  const VecX& free_response() const { return Yfree_; }
  const qp::QpProblem& qp_problem() const { return qp_; }
  /// The QP solver's full report of the last solve (residuals, gap, multipliers).
  const qp::QpResult& qp_result() const { return solver_.last_result(); }
  /// The result of the last solve().
  const IncrementalMpcResult& last_result() const { return result_; }

 private:
  std::string_view check_data() const;

  void group_rows_by_span();
  void assemble_qp();
  // The hot loops, compiled for AVX2 too (core/simd_clones.hpp). They stay private: GCC
  // emits the dispatcher of a cloned function in each file that calls it, and only
  // incremental_mpc.cpp holds the clones.
  RIDGELINE_SIMD_CLONES void collect_plant_nonzeros();
  void list_b_nonzeros();  // after a change of some B_j (collect_plant_nonzeros)
  // w_j of eq. 7 (n_s values), also kept in known_terms_[j] for the solution's simulation.
  // zero_increment: the caller knows the forecast increment Δd_j to be zero.
  const double* known_term(int j, bool zero_increment);
  RIDGELINE_SIMD_CLONES void forward_pass();
  RIDGELINE_SIMD_CLONES void build_cost();
  RIDGELINE_SIMD_CLONES void write_hessian_block(int lo, int hi);
  RIDGELINE_SIMD_CLONES void assemble_soft_rows();
  // Cloned as the others (its whole-column products in AVX2) but without fused multiply-adds:
  // each product rounds before it is added, as in the baseline code it replaced, so the
  // predictions (and the next step's nominal built on them) are the same to the bit.
  RIDGELINE_SIMD_CLONES RIDGELINE_NO_CONTRACTION void extract_solution(
      const qp::QpResult& qp_result);
  void resize_soft_rows(int needed);
  void renumber_soft_rows(int old_soft_rows_in_qp);

  static constexpr int kSoftRowBlock = 16;
  int soft_rows_in_qp_ = 0;

  IncrementalMpcDims dims_;
  IncrementalMpcOptions options_;
  int ns_, nu_, ny_, nd_, np_, nc_, ng_, nz_;
  int input_rows_begin_, output_rows_begin_, soft_rows_begin_;

  IncrementalMpcData data_;
  IncrementalMpcResult result_;
  qp::QpProblem qp_;
  qp::QpSolver solver_;

  // The exact nonzeros of the stage matrices A_j (all steps, in step order) and of C.
  struct Entry {
    int row, col;
    double value;
    bool operator==(const Entry&) const = default;  // a listing that changed (value by ==)
  };
  // Listed by step, then row: row k of A_j is a_entries_[a_row_begin_[j·n_s + k],
  // a_row_begin_[j·n_s + k + 1]), and row k of C is c_entries_[c_row_begin_[k], …[k + 1]).
  std::vector<Entry> a_entries_;  // capacity Np·n_s²
  std::vector<int> a_row_begin_;  // Np·n_s + 1 offsets into a_entries_
  // Of a_entries_[e]: its index in A_j's column-major storage (col·n_s + row), and its row's
  // bit in a row mask (bit row & 63), for the values' update at each step.
  std::vector<int> a_offsets_;
  std::vector<std::uint64_t> a_row_bits_;
  std::vector<Entry> c_entries_;  // capacity n_y·n_s, the first c_count_ used
  std::vector<int> c_row_begin_;  // n_y + 1 offsets into c_entries_
  // The nonzeros of B_j for the moves (j < Nc), listed the same way (row k of B_j:
  // b_entries_[b_row_begin_[j·n_s + k], …[j·n_s + k + 1]); col is the input).
  std::vector<Entry> b_entries_;  // capacity Nc·n_s·n_u
  std::vector<int> b_row_begin_;  // Nc·n_s + 1
  // The B_j of the moves as last listed (Nc·n_s·n_u, column-major each), whether a listing
  // exists, and each state's inputs in some B_j row (bit c: input c; n_s).
  std::vector<double> b_copy_;
  bool b_listed_ = false;
  std::vector<std::uint64_t> b_reach_;
  // A plant of 4 to 8 states takes the free response's A_j·Δs, and the solution's simulation
  // A_j·Δs and B_j·Δu, over whole columns (dense_columns_product), not over the listed nonzeros.
  static constexpr int kMinDenseStates = 4, kMaxDenseStates = 8;
  bool dense_ = false;
  int c_count_ = 0;
  // Each output reads one state (C selects states, as the UAV's position): c_entries_[k] is
  // row k's entry, and the outputs' sums need no loop over a row's entries.
  bool c_one_per_row_ = false;
  std::vector<char> a_pattern_;  // n_s×n_s: nonzero in some A_j
  // What changed since the last build_prediction, as masks of rows (bit k: row k; used when
  // n_s ≤ 64): the rows of each A_j whose values changed, or all if it was listed anew (Np),
  // and the rows of the B_j of the moves (Nc); C as a whole. The dependents of each state in
  // A_j (Np·n_s): bit k where A_j(k, l) is nonzero, for state l; the sources of each row of C
  // (n_y): bit l where C(k, l) is nonzero. Which rows of Φ (Np·n_y) the last pass computed
  // anew. Rows that did not change keep their values, which is valid once a pass has run with
  // the present reaches (rows_valid_).
  std::vector<std::uint64_t> a_changed_rows_, a_dependents_, b_changed_rows_, c_sources_;
  std::vector<int> phi_changed_;
  // The forward pass's row updates as made by the last pass that decided them row by row,
  // replayed while what decided them is the same (see forward_pass): each names the row it
  // writes, the rows and coefficients it sums (the coefficients read at each update, in
  // a_entries_ and c_entries_, which keep their places while the listings stay), and for Φ its
  // row and group (to mark them for assemble_soft_rows and build_cost). Rows of more than
  // kMaxRowTerms terms are not recorded (the pass then decides every step).
  static constexpr int kMaxRowTerms = 4;
  struct RowUpdate {
    double* row;                              // the row's start (B_j's entries by column)
    double* target;                           // the row at its span's start
    const double* base;                       // Φ's row above at the span (null: none)
    const double* coefficient[kMaxRowTerms];  // the terms' coefficients
    const double* source[kMaxRowTerms];       // the terms' source rows at the span
    int size, count;                          // the span's columns, the terms
    int b_begin, b_end;                       // Γ: the row's entries of B_j (j < Nc)
    int phi_row, group;                       // Φ: the row and its output's group (−1: none)
  };
  // The recorded updates and what decided them: the listings (a count of their changes), the
  // masks, the rows computed. They point into the heap storage of Γ, Φ and the listings, which
  // stays in place while the controller lives (a move keeps it; the controller is not copyable:
  // its QP solver's workspace is not).
  struct RecordedUpdates {
    std::vector<RowUpdate> gamma, phi;        // capacity Np·n_s, Np·n_y
    std::vector<int> gamma_begin, phi_begin;  // Np + 1 each: step j's updates
    bool valid = false;
    std::uint64_t listing = 0, alternating = 0, no_history = 0;
    std::vector<std::uint64_t> a_changed, b_changed;  // Np, Nc
    int rows_computed = 0;
  };
  RecordedUpdates updates_;
  std::uint64_t listing_generation_ = 0;
  // Rows of Φ changed since their range over the move box was computed (Np·n_y), and groups
  // whose rows changed since their block of H was summed (n_y); the group of each output
  // (−1: none).
  std::vector<int> range_stale_, group_stale_, output_group_;
  bool groups_disjoint_ = true;
  std::uint64_t box_changed_ = ~std::uint64_t{0};  // inputs whose move box changed (assemble_qp)
  // Every side of the move box is finite and no lower side is above its upper one (an inverted
  // box is not rejected before the QP; assemble_qp, when the box changed).
  bool box_regular_ = false;
  bool box_symmetric_ = false;  // and every lower side is the upper one negated (the UAV's)
  bool h_valid_ = false;  // H was written in full once with the present groups
  bool c_changed_ = true;
  bool rows_valid_ = false;

  // Φ and Γ order their columns by input, then move (see build_prediction).
  RowMatX Phi_;  // (Np·n_y)×(Nc·n_u); moves not yet started stay zero
  // ((Np + 3)·n_s)×(Nc·n_u): Γ_{−1} = 0, Γ_0, …, Γ_{Np−1} (block j + 1 holds Γ_j), then two
  // alternating blocks, stored by state (state k of block b is row k·(Np + 3) + b); valid inside
  // each row's span. A row is kept for every step, so that a row that does not change is not
  // computed again the next step, unless it changes at every step: then it alternates between
  // the last two blocks (see forward_pass).
  RowMatX Gamma_;
  std::uint64_t history_valid_ = 0;  // rows whose blocks hold the last pass's values
  VecX Yfree_;                       // Np·n_y
  VecX qdiag_;                       // Np·n_y: diagonal of Q̄
  VecX ds_, dsn_, y_;                // n_s, n_s, n_y
  // The known terms w_j of the last forward pass: a column of state_offset, or of W_ where a
  // forecast increment adds E_j·Δd_j (n_s × Np).
  MatX W_;
  std::vector<const double*> known_terms_;

  // Reach (bit c: input c) of each state and output component (collect_plant_nonzeros), and
  // the reaches Γ and Φ were last cleared for.
  std::vector<std::uint64_t> state_reach_, output_reach_, phi_reach_, gamma_reach_;
  // The span of a reach in Φ's and Γ's column order once every move has started (steps
  // j ≥ Nc): the columns [lo, hi) from its first to its last input's block. Inputs inside the
  // span but outside the reach hold exact zeros, so one contiguous loop over the span gives
  // the same sums as the per-input loops.
  std::vector<int> state_span_lo_, state_span_hi_;    // n_s
  std::vector<int> output_span_lo_, output_span_hi_;  // n_y
  // The rows of Φ grouped by span (build_cost sums each group's rank updates over its span):
  // group g has the span [lo, hi) and the rows group_rows_[begin_g, begin_{g+1}).
  std::vector<int> group_lo_, group_hi_, group_begin_;  // n_y, n_y, n_y + 1
  std::vector<int> group_rows_;                         // Np·n_y
  int groups_ = 0;
  RowMatX Hp_;  // (Nc·n_u)²: ΦᵀQ̄Φ in Φ's column order, lower triangle (a ≥ b)
  // build_cost's packing of one group: its rows' starts in Φ (at the span) and their entries
  // times q_r, one row after the other (Np·n_y rows of the span's size at most).
  std::vector<const double*> row_starts_;
  VecX scaled_rows_;
  VecX gradient_weights_;  // Np·n_y: each row's weight in f_u, −2q_r(r_r − y_free,r)
  VecX fp_;             // Nc·n_u: f_u in Φ's column order
  RowMatX soft_block_;  // capacity × Nc·n_u: the kept soft rows' aᵀΦ_j in Φ's column order
  // The range of each row of Φ over the move box, min and max of φ_rᵀΔU (assemble_soft_rows).
  VecX phi_min_, phi_max_;  // Np·n_y
  // This step's soft rows that can be violated (indices into data's rows), in data's order,
  // with their bounds on aᵀΦ_j ΔU + σ.
  std::vector<int> kept_rows_;  // capacity entries, the first kept_count_ used
  VecX kept_bounds_;            // capacity
  int kept_count_ = 0;

  // The last solve's QP soft rows by (group, source, step), to renumber the QP's hot start;
  // they lead the QP's soft rows, and the rows after them are padding.
  struct SoftRowKey {
    int group = 0, source = 0, step = 0;
    auto operator<=>(const SoftRowKey&) const = default;
  };
  std::vector<SoftRowKey> previous_keys_;  // capacity entries, the first previous_count_ used
  int previous_count_ = 0;
  bool previous_sorted_ = false;
  std::vector<int> row_map_;  // the QP's rows at capacity: old row → new row or −1
};

}  // namespace ridgeline::mpc
