#include "mpc/incremental_mpc.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>
#include <string>

#include "core/error.hpp"

namespace ridgeline::mpc {

namespace {

using Clock = std::chrono::steady_clock;

double elapsed_us(Clock::time_point since) {
  return std::chrono::duration<double, std::micro>(Clock::now() - since).count();
}

void require(bool ok, const std::string& field, const std::string& reason) {
  if (!ok) throw InputError(field, reason);
}

bool has_shape(const MatX& m, int rows, int cols) { return m.rows() == rows && m.cols() == cols; }

// dst[0..n) += a·src[0..n) for rows of different matrices.
inline __attribute__((always_inline)) void axpy(double* __restrict dst, int n, double a,
                                                const double* __restrict src) {
  for (int i = 0; i < n; ++i) dst[i] += a * src[i];
}

// The same four at a time in vector code, for the soft rows' sums of two rows of Φ (Nc·n_u
// long, 30 for the UAV), where the vectorizer's set-up costs as much as the loop.
inline __attribute__((always_inline)) void axpy4(double* __restrict dst, int n, double a,
                                                 const double* __restrict src) {
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    Vec4 x, y;
    std::memcpy(&x, src + i, sizeof x);
    std::memcpy(&y, dst + i, sizeof y);
    y += a * x;
    std::memcpy(dst + i, &y, sizeof y);
  }
  for (; i < n; ++i) dst[i] += a * src[i];
}

// f[0..n) += Σ_r weights[r]·rows[r][0..n) over `count` rows, summed row after row as a loop of
// axpys would (the same sums), but with a panel of up to six vectors of f kept in registers
// over all the rows: each entry is loaded and stored once, and the panel's sums are
// independent chains instead of one load, multiply-add and store a row. The columns past the
// last multiple of four are summed in the lanes of one more vector.
template <int V>
inline __attribute__((always_inline)) void add_weighted_rows_panel(double* f,
                                                                   const double* const* rows,
                                                                   const double* weights, int count,
                                                                   int q) {
  Vec4 acc[V];
  std::memcpy(acc, f + q, sizeof acc);
  for (int r = 0; r < count; ++r) {
    const double* p = rows[r] + q;
    const double w = weights[r];
    for (int v = 0; v < V; ++v) {
      Vec4 x;
      std::memcpy(&x, p + 4 * v, sizeof x);
      acc[v] += w * x;
    }
  }
  std::memcpy(f + q, acc, sizeof acc);
}

// The panel of the last v < 6 vectors (none when v is 0), its width a constant of each.
template <int V>
inline __attribute__((always_inline)) void add_weighted_rows_last_panel(int v, double* f,
                                                                        const double* const* rows,
                                                                        const double* weights,
                                                                        int count, int q) {
  if (v == V) {
    add_weighted_rows_panel<V>(f, rows, weights, count, q);
  } else if constexpr (V > 1) {
    add_weighted_rows_last_panel<V - 1>(v, f, rows, weights, count, q);
  }
}

inline __attribute__((always_inline)) void add_weighted_rows(double* f, int n,
                                                             const double* const* rows,
                                                             const double* weights, int count) {
  int q = 0;
  for (; q + 24 <= n; q += 24) add_weighted_rows_panel<6>(f, rows, weights, count, q);
  add_weighted_rows_last_panel<5>((n - q) / 4, f, rows, weights, count, q);
  q = n / 4 * 4;
  const int tail = n - q;
  if (tail == 0) return;
  // The tail's columns as lanes of one vector (the unused lanes sum zeros): as scalars, a
  // single tail column's sum over the rows was vectorized by GCC into products rounded before
  // an in-order sum, not the multiply-adds of the axpys it replaces.
  Vec4 t = {f[q], tail > 1 ? f[q + 1] : 0.0, tail > 2 ? f[q + 2] : 0.0, 0.0};
  for (int r = 0; r < count; ++r) {
    const double* p = rows[r] + q;
    const Vec4 x = {p[0], tail > 1 ? p[1] : 0.0, tail > 2 ? p[2] : 0.0, 0.0};
    t += weights[r] * x;
  }
  f[q] = t[0];
  if (tail > 1) f[q + 1] = t[1];
  if (tail > 2) f[q + 2] = t[2];
}

// dst[0..n) = a·src[0..n), four at a time (short rows, as axpy4: build_cost's rows of a span,
// the soft rows' single terms).
inline __attribute__((always_inline)) void scale4(double* __restrict dst, int n, double a,
                                                  const double* __restrict src) {
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    Vec4 x;
    std::memcpy(&x, src + i, sizeof x);
    x = a * x;
    std::memcpy(dst + i, &x, sizeof x);
  }
  for (; i < n; ++i) dst[i] = a * src[i];
}

// dst[0..n) = base[0..n) + Σ_t a_t·src_t[0..n) over the `count` terms of one row, summed in the
// terms' order; base null means zero. The common counts keep the partial sums in registers, so
// each entry of dst is stored once.
// Inlined into its callers, the forward pass's clones, so that it is compiled for AVX2 too.
inline __attribute__((always_inline)) void combine_row(double* __restrict dst, int n,
                                                       const double* __restrict base,
                                                       const double* a, const double* const* src,
                                                       int count) {
  if (base == nullptr && count == 1) {
    const double a0 = a[0];
    const double* __restrict s0 = src[0];
    for (int i = 0; i < n; ++i) dst[i] = a0 * s0[i];
  } else if (base == nullptr && count == 2) {
    const double a0 = a[0], a1 = a[1];
    const double* __restrict s0 = src[0];
    const double* __restrict s1 = src[1];
    for (int i = 0; i < n; ++i) dst[i] = a0 * s0[i] + a1 * s1[i];
  } else if (base == nullptr && count == 3) {
    const double a0 = a[0], a1 = a[1], a2 = a[2];
    const double* __restrict s0 = src[0];
    const double* __restrict s1 = src[1];
    const double* __restrict s2 = src[2];
    int i = 0;
    for (; i + 4 <= n; i += 4) {  // four at a time, without the vectorizer's set-up
      Vec4 v0, v1, v2;
      std::memcpy(&v0, s0 + i, sizeof v0);
      std::memcpy(&v1, s1 + i, sizeof v1);
      std::memcpy(&v2, s2 + i, sizeof v2);
      const Vec4 out = a0 * v0 + a1 * v1 + a2 * v2;
      std::memcpy(dst + i, &out, sizeof out);
    }
    for (; i < n; ++i) dst[i] = a0 * s0[i] + a1 * s1[i] + a2 * s2[i];
  } else if (base != nullptr && count == 1) {
    const double a0 = a[0];
    const double* __restrict s0 = src[0];
    int i = 0;
    for (; i + 4 <= n; i += 4) {
      Vec4 b, v0;
      std::memcpy(&b, base + i, sizeof b);
      std::memcpy(&v0, s0 + i, sizeof v0);
      const Vec4 out = b + a0 * v0;
      std::memcpy(dst + i, &out, sizeof out);
    }
    for (; i < n; ++i) dst[i] = base[i] + a0 * s0[i];
  } else {
    if (base == nullptr) {
      std::fill_n(dst, n, 0.0);
    } else {
      std::copy_n(base, n, dst);
    }
    for (int t = 0; t < count; ++t) axpy(dst, n, a[t], src[t]);
  }
}

// The number of nonzero entries of x[0..n), four lanes at a time (a NaN counts). Inlined into
// the clones of collect_plant_nonzeros and forward_pass: a call through the clones' dispatcher
// for 49 entries cost about as much as the count.
inline __attribute__((always_inline)) int count_nonzeros(const double* x, int n) {
  Mask4 counts = {};  // lane-wise: a comparison gives −1 where true
  const Vec4 zero = {};
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    Vec4 v;
    std::memcpy(&v, x + i, sizeof v);
    counts -= v != zero;
  }
  int count = static_cast<int>(counts[0] + counts[1] + counts[2] + counts[3]);
  for (; i < n; ++i) count += x[i] != 0.0 ? 1 : 0;
  return count;
}

// out[0..rows) = w[0..rows) + Σ_{l < cols} M(:, l)·x[l] for a column-major matrix M of 4 to 8
// rows (kMinDenseStates to kMaxDenseStates; leading dimension `rows`): each column is two
// four-lane loads, rows 0–3 and rows rows−4 to rows−1 (overlapping when rows < 8, never past the
// column's end), and two vector multiply-adds, instead of a loop over each row's nonzeros. Each
// row sums in the order of the sparse loop it replaces (w first, then by column) and a zero
// entry adds an exact zero, so the values are the same for a finite x (the sign of an exact
// zero aside). A NaN or infinite x[l] makes every row NaN here (0·∞), only the rows reading
// state l in the sparse loop: in the free response the QP that follows is rejected as not
// finite either way, and the solution's simulation then reports NaN predictions either way.
inline __attribute__((always_inline)) void dense_columns_product(const double* M, int rows,
                                                                 int cols, const double* w,
                                                                 const double* x, double* out) {
  const int tail = rows - 4;
  Vec4 lo, hi;
  std::memcpy(&lo, w, sizeof lo);
  std::memcpy(&hi, w + tail, sizeof hi);
  for (int l = 0; l < cols; ++l) {
    Vec4 c0, c1;
    std::memcpy(&c0, M + rows * l, sizeof c0);
    std::memcpy(&c1, M + rows * l + tail, sizeof c1);
    lo += c0 * x[l];
    hi += c1 * x[l];
  }
  std::memcpy(out + tail, &hi, sizeof hi);  // the rows both halves hold are equal
  std::memcpy(out, &lo, sizeof lo);
}

// dst(i, j) = src(i, j) for i < rows, j < cols: src row-major (leading dimension src_ld), dst
// column-major (dst_ld). In 4 × 4 tiles, each four rows loaded as vectors and stored as four
// columns, instead of one strided load an entry.
inline __attribute__((always_inline)) void transpose(const double* __restrict src,
                                                     Eigen::Index src_ld, int rows, int cols,
                                                     double* __restrict dst, Eigen::Index dst_ld) {
  const int full_rows = rows / 4 * 4, full_cols = cols / 4 * 4;
  for (int i = 0; i < full_rows; i += 4) {
    const double* s = src + i * src_ld;
    for (int j = 0; j < full_cols; j += 4) {
      Vec4 r0, r1, r2, r3;
      std::memcpy(&r0, s + j, sizeof r0);
      std::memcpy(&r1, s + src_ld + j, sizeof r1);
      std::memcpy(&r2, s + 2 * src_ld + j, sizeof r2);
      std::memcpy(&r3, s + 3 * src_ld + j, sizeof r3);
      transpose4(r0, r1, r2, r3);  // now columns j … j + 3
      double* d = dst + j * dst_ld + i;
      std::memcpy(d, &r0, sizeof r0);
      std::memcpy(d + dst_ld, &r1, sizeof r1);
      std::memcpy(d + 2 * dst_ld, &r2, sizeof r2);
      std::memcpy(d + 3 * dst_ld, &r3, sizeof r3);
    }
    for (int j = full_cols; j < cols; ++j) {
      for (int k = 0; k < 4; ++k) dst[j * dst_ld + i + k] = s[k * src_ld + j];
    }
  }
  for (int j = 0; j < cols; ++j) {
    for (int i = full_rows; i < rows; ++i) dst[j * dst_ld + i] = src[i * src_ld + j];
  }
}

}  // namespace

void IncrementalMpcData::set_time_invariant(const MatX& A_, const MatX& B_, const MatX& C_,
                                            const MatX& E_) {
  for (auto& a : A) a = A_;
  for (auto& b : B) b = B_;
  if (E_.size() > 0) {
    for (auto& e : E) e = E_;
  }
  C = C_;
}

IncrementalMpc::IncrementalMpc(const IncrementalMpcDims& dims, const IncrementalMpcOptions& options)
    : dims_(dims), options_(options), solver_(options.qp_settings) {
  require(dims.state_dim >= 1, "dims.state_dim", "must be >= 1");
  require(dims.input_dim >= 1 && dims.input_dim <= 64, "dims.input_dim",
          "must be between 1 and 64 (an input set is a 64-bit mask)");
  require(dims.output_dim >= 1, "dims.output_dim", "must be >= 1");
  require(dims.disturbance_dim >= 0, "dims.disturbance_dim", "must be >= 0");
  require(dims.soft_row_capacity >= 0, "dims.soft_row_capacity", "must be >= 0");
  require(dims.slack_groups >= 0, "dims.slack_groups", "must be >= 0");
  require(dims.soft_row_capacity == 0 || dims.slack_groups >= 1, "dims.slack_groups",
          "must be >= 1 when soft_row_capacity > 0");
  require(options.prediction_horizon >= 1, "options.prediction_horizon", "must be >= 1");
  require(options.control_horizon >= 1 && options.control_horizon <= options.prediction_horizon,
          "options.control_horizon", "must satisfy 1 <= Nc <= Np");
  require(options.output_weight.size() == dims.output_dim, "options.output_weight",
          "needs output_dim entries");
  require((options.output_weight.array() >= 0.0).all() && options.output_weight.allFinite(),
          "options.output_weight", "entries must be finite and >= 0");
  require(options.terminal_output_weight.size() == 0 ||
              options.terminal_output_weight.size() == dims.output_dim,
          "options.terminal_output_weight", "needs output_dim entries or none");
  require((options.terminal_output_weight.array() >= 0.0).all() &&
              options.terminal_output_weight.allFinite(),
          "options.terminal_output_weight", "entries must be finite and >= 0");
  require(options.move_weight.size() == dims.input_dim, "options.move_weight",
          "needs input_dim entries");
  require((options.move_weight.array() > 0.0).all() && options.move_weight.allFinite(),
          "options.move_weight", "entries must be finite and > 0");
  const auto check_limits = [](const VecX& lo, const VecX& hi, int dim, const char* lo_name,
                               const char* hi_name) {
    require(lo.size() == 0 || lo.size() == dim, lo_name,
            "needs " + std::to_string(dim) + " entries or none");
    require(hi.size() == 0 || hi.size() == dim, hi_name,
            "needs " + std::to_string(dim) + " entries or none");
    require(!lo.hasNaN() && !hi.hasNaN(), std::string(lo_name) + "/" + hi_name, "has NaN");
    if (lo.size() == dim && hi.size() == dim) {
      require((lo.array() <= hi.array()).all(), std::string(lo_name) + "/" + hi_name,
              "lower limit above upper limit");
    }
  };
  check_limits(options.input_min, options.input_max, dims.input_dim, "options.input_min",
               "options.input_max");
  check_limits(options.move_min, options.move_max, dims.input_dim, "options.move_min",
               "options.move_max");
  check_limits(options.output_min, options.output_max, dims.output_dim, "options.output_min",
               "options.output_max");
  require(std::isfinite(options.slack_linear_weight) && options.slack_linear_weight > 0.0,
          "options.slack_linear_weight", "must be finite and > 0");
  require(std::isfinite(options.slack_quadratic_weight) && options.slack_quadratic_weight > 0.0,
          "options.slack_quadratic_weight", "must be finite and > 0");

  ns_ = dims.state_dim;
  nu_ = dims.input_dim;
  ny_ = dims.output_dim;
  nd_ = dims.disturbance_dim;
  np_ = options.prediction_horizon;
  nc_ = options.control_horizon;
  ng_ = dims.slack_groups;
  nz_ = nc_ * nu_ + ng_;
  const int cap = dims.soft_row_capacity;

  data_.A.assign(np_, MatX::Identity(ns_, ns_));
  data_.B.assign(np_, MatX::Zero(ns_, nu_));
  data_.E.assign(np_, MatX::Zero(ns_, nd_));
  data_.C = MatX::Zero(ny_, ns_);
  data_.delta_state = VecX::Zero(ns_);
  data_.output = VecX::Zero(ny_);
  data_.state = VecX::Zero(ns_);
  data_.previous_input = VecX::Zero(nu_);
  data_.disturbance_delta = MatX::Zero(nd_, np_);
  data_.state_offset = MatX::Zero(ns_, np_);
  data_.reference = MatX::Zero(ny_, np_);
  data_.input_min = MatX::Constant(nu_, nc_, -qp::kInfinity);
  data_.input_max = MatX::Constant(nu_, nc_, qp::kInfinity);
  data_.move_min = MatX::Constant(nu_, nc_, -qp::kInfinity);
  data_.move_max = MatX::Constant(nu_, nc_, qp::kInfinity);
  data_.output_min = MatX::Constant(ny_, np_, -qp::kInfinity);
  data_.output_max = MatX::Constant(ny_, np_, qp::kInfinity);
  if (options.input_min.size() > 0) data_.input_min.colwise() = options.input_min;
  if (options.input_max.size() > 0) data_.input_max.colwise() = options.input_max;
  if (options.move_min.size() > 0) data_.move_min.colwise() = options.move_min;
  if (options.move_max.size() > 0) data_.move_max.colwise() = options.move_max;
  if (options.output_min.size() > 0) data_.output_min.colwise() = options.output_min;
  if (options.output_max.size() > 0) data_.output_max.colwise() = options.output_max;
  data_.soft_step.assign(cap, 0);
  data_.soft_group.assign(cap, 0);
  data_.soft_source.assign(cap, 0);
  data_.soft_normal = MatX::Zero(ny_, cap);
  data_.soft_bound = VecX::Zero(cap);

  a_entries_.resize(static_cast<std::size_t>(np_) * ns_ * ns_);
  a_offsets_.resize(a_entries_.size());
  a_row_bits_.resize(a_entries_.size());
  a_row_begin_.assign(static_cast<std::size_t>(np_) * ns_ + 1, 0);
  c_entries_.resize(static_cast<std::size_t>(ny_) * ns_);
  c_row_begin_.assign(ny_ + 1, 0);
  b_entries_.resize(static_cast<std::size_t>(nc_) * ns_ * nu_);
  b_row_begin_.assign(static_cast<std::size_t>(nc_) * ns_ + 1, 0);
  b_copy_.assign(static_cast<std::size_t>(nc_) * ns_ * nu_, 0.0);
  b_reach_.assign(ns_, 0);
  a_pattern_.assign(static_cast<std::size_t>(ns_) * ns_, 0);
  updates_.gamma.reserve(static_cast<std::size_t>(np_) * ns_);
  updates_.phi.reserve(static_cast<std::size_t>(np_) * ny_);
  updates_.gamma_begin.assign(np_ + 1, 0);
  updates_.phi_begin.assign(np_ + 1, 0);
  updates_.a_changed.assign(np_, 0);
  updates_.b_changed.assign(nc_, 0);
  Phi_ = RowMatX::Zero(np_ * ny_, nc_ * nu_);
  Gamma_ = RowMatX::Zero((np_ + 3) * ns_, nc_ * nu_);
  a_changed_rows_.assign(np_, ~std::uint64_t{0});
  a_dependents_.assign(static_cast<std::size_t>(np_) * ns_, 0);
  b_changed_rows_.assign(nc_, ~std::uint64_t{0});
  c_sources_.assign(ny_, 0);
  phi_changed_.assign(static_cast<std::size_t>(np_) * ny_, 1);
  range_stale_.assign(static_cast<std::size_t>(np_) * ny_, 1);
  output_group_.assign(ny_, -1);
  group_stale_.assign(ny_, 1);
  Yfree_ = VecX::Zero(np_ * ny_);
  qdiag_ = VecX::Zero(np_ * ny_);
  for (int j = 0; j < np_; ++j) {
    const bool terminal = j == np_ - 1 && options.terminal_output_weight.size() == ny_;
    qdiag_.segment(j * ny_, ny_) =
        terminal ? options.terminal_output_weight : options.output_weight;
  }
  dense_ = ns_ >= kMinDenseStates && ns_ <= kMaxDenseStates;
  ds_ = VecX::Zero(ns_);
  dsn_ = VecX::Zero(ns_);
  y_ = VecX::Zero(ny_);
  W_ = MatX::Zero(ns_, np_);
  known_terms_.assign(np_, nullptr);
  state_reach_.assign(ns_, 0);
  output_reach_.assign(ny_, 0);
  phi_reach_.assign(ny_, 0);
  gamma_reach_.assign(ns_, 0);
  state_span_lo_.assign(ns_, 0);
  state_span_hi_.assign(ns_, 0);
  output_span_lo_.assign(ny_, 0);
  output_span_hi_.assign(ny_, 0);
  group_lo_.assign(ny_, 0);
  group_hi_.assign(ny_, 0);
  group_begin_.assign(ny_ + 1, 0);
  group_rows_.assign(np_ * ny_, 0);
  Hp_ = RowMatX::Zero(nc_ * nu_, nc_ * nu_);
  fp_ = VecX::Zero(nc_ * nu_);
  soft_block_ = RowMatX::Zero(cap, nc_ * nu_);
  scaled_rows_ = VecX::Zero(static_cast<Eigen::Index>(np_) * ny_ * nc_ * nu_);
  row_starts_.assign(static_cast<std::size_t>(np_) * ny_, nullptr);
  gradient_weights_ = VecX::Zero(np_ * ny_);
  phi_min_ = VecX::Zero(np_ * ny_);
  phi_max_ = VecX::Zero(np_ * ny_);
  kept_rows_.assign(cap, 0);
  kept_bounds_ = VecX::Zero(cap);
  previous_keys_.assign(cap, SoftRowKey{});

  // QP layout: rows [input limits (Nc·n_u) | hard output limits (Np·n_y, optional) | soft].
  input_rows_begin_ = 0;
  output_rows_begin_ = nc_ * nu_;
  soft_rows_begin_ = output_rows_begin_ + (options.hard_output_limits ? np_ * ny_ : 0);
  soft_rows_in_qp_ = 0;
  row_map_.assign(soft_rows_begin_ + cap, -1);
  const int m = soft_rows_begin_;
  qp_.H = MatX::Zero(nz_, nz_);
  qp_.f = VecX::Zero(nz_);
  qp_.lb = VecX::Zero(nz_);
  qp_.ub = VecX::Constant(nz_, qp::kInfinity);
  qp_.G = MatX::Zero(m, nz_);
  qp_.lg = VecX::Constant(m, -qp::kInfinity);
  qp_.ug = VecX::Constant(m, qp::kInfinity);
  qp_.A = MatX::Zero(0, nz_);
  qp_.b = VecX::Zero(0);
  // u_{k+i,c} = u_{k−1,c} + Σ_{l≤i} Δu_{k+l,c}: per input a lower-triangular block of ones
  // (rows and columns in the QP's order, input then move).
  for (int c = 0; c < nu_; ++c) {
    for (int i = 0; i < nc_; ++i) {
      for (int l = 0; l <= i; ++l) qp_.G(input_rows_begin_ + c * nc_ + i, c * nc_ + l) = 1.0;
    }
  }
  // Slack Hessian and gradient are constant.
  for (int g = 0; g < ng_; ++g) {
    qp_.H(nc_ * nu_ + g, nc_ * nu_ + g) = 2.0 * options.slack_quadratic_weight;
    qp_.f[nc_ * nu_ + g] = options.slack_linear_weight;
  }

  result_.first_move = VecX::Zero(nu_);
  result_.first_input = VecX::Zero(nu_);
  result_.moves = VecX::Zero(nc_ * nu_);
  result_.predicted_outputs = MatX::Zero(ny_, np_);
  result_.predicted_states = MatX::Zero(ns_, np_);
  result_.slack = VecX::Zero(ng_);
}

std::string_view IncrementalMpc::check_data() const {
  const IncrementalMpcData& d = data_;
  if (static_cast<int>(d.A.size()) != np_ || static_cast<int>(d.B.size()) != np_ ||
      static_cast<int>(d.E.size()) != np_) {
    return "A/B/E (horizon length)";
  }
  for (int j = 0; j < np_; ++j) {
    if (!has_shape(d.A[j], ns_, ns_)) return "A[j]";
    if (!has_shape(d.B[j], ns_, nu_)) return "B[j]";
    if (!has_shape(d.E[j], ns_, nd_)) return "E[j]";
  }
  if (!has_shape(d.C, ny_, ns_)) return "C";
  if (d.delta_state.size() != ns_) return "delta_state";
  if (d.output.size() != ny_) return "output";
  if (d.state.size() != ns_) return "state";
  if (d.previous_input.size() != nu_) return "previous_input";
  if (!has_shape(d.disturbance_delta, nd_, np_)) return "disturbance_delta";
  if (!has_shape(d.state_offset, ns_, np_)) return "state_offset";
  if (!has_shape(d.reference, ny_, np_)) return "reference";
  if (!has_shape(d.input_min, nu_, nc_) || !has_shape(d.input_max, nu_, nc_)) {
    return "input_min/input_max";
  }
  if (!has_shape(d.move_min, nu_, nc_) || !has_shape(d.move_max, nu_, nc_)) {
    return "move_min/move_max";
  }
  if (!has_shape(d.output_min, ny_, np_) || !has_shape(d.output_max, ny_, np_)) {
    return "output_min/output_max";
  }
  const int cap = dims_.soft_row_capacity;
  if (static_cast<int>(d.soft_step.size()) != cap || static_cast<int>(d.soft_group.size()) != cap ||
      static_cast<int>(d.soft_source.size()) != cap || !has_shape(d.soft_normal, ny_, cap) ||
      d.soft_bound.size() != cap || d.soft_row_count < 0 || d.soft_row_count > cap) {
    return "soft rows (storage)";
  }
  // One pass without branches over every row (a hundred or more a step; a negative index
  // compares as a large unsigned one), and only when it finds a bad row, which field.
  const int* steps = d.soft_step.data();
  const int* groups = d.soft_group.data();
  const int* sources = d.soft_source.data();
  bool bad = false;
  for (int r = 0; r < d.soft_row_count; ++r) {
    bad |= (static_cast<unsigned>(steps[r]) >= static_cast<unsigned>(np_)) |
           (static_cast<unsigned>(groups[r]) >= static_cast<unsigned>(ng_)) | (sources[r] < 0);
  }
  if (!bad) return {};
  for (int r = 0; r < d.soft_row_count; ++r) {
    if (d.soft_step[r] < 0 || d.soft_step[r] >= np_) return "soft_step";
    if (d.soft_group[r] < 0 || d.soft_group[r] >= ng_) return "soft_group";
    if (d.soft_source[r] < 0) return "soft_source";
  }
  return {};
}

void IncrementalMpc::collect_plant_nonzeros() {
  // Plant matrices such as I + Δt·A_c are mostly zeros (13 of 49 entries for the UAV): listing
  // the nonzeros once lets the rows of Γ (and, for plants outside 4 to 8 states, the free
  // response and the solution's simulation) skip the zeros without testing them again.
  const IncrementalMpcData& d = data_;
  int n = 0;
  bool same = true;  // every A_j so far has the nonzero positions listed by the last call
  // Listed by row (then column): the forward pass sums each row of Γ_j in one loop, and a
  // row's terms keep the order of the column-major listing this replaced (column ascending).
  for (int j = 0; j < np_; ++j) {
    const int old_begin = a_row_begin_[j * ns_], old_end = a_row_begin_[(j + 1) * ns_];
    const double* A = d.A[j].data();  // column-major n_s×n_s
    // The common case (a plant whose Jacobian keeps its structure): as many nonzeros as last
    // time, and nonzero at every listed position, is the same set; only the values are read,
    // noting the rows whose values changed (bit k: row k).
    if (same && n == old_begin && count_nonzeros(A, ns_ * ns_) == old_end - old_begin) {
      // Compared as bits: equal bits give equal sums (a NaN kept gives the same NaN rows).
      // A listed entry that became ±0 has no bit set outside its sign.
      // Each entry's place in A_j and its row's bit were noted when it was listed.
      std::uint64_t changed = 0, zero = 0;
      Entry* __restrict entries = a_entries_.data();
      const int* __restrict offsets = a_offsets_.data();
      const std::uint64_t* __restrict row_bits = a_row_bits_.data();
      for (int e = old_begin; e < old_end; ++e) {
        const double v = A[offsets[e]];
        const std::uint64_t bits = std::bit_cast<std::uint64_t>(v);
        const std::uint64_t old = std::bit_cast<std::uint64_t>(entries[e].value);
        changed |= bits != old ? row_bits[e] : 0;
        zero |= std::uint64_t{(bits << 1) == 0};
        entries[e].value = v;
      }
      if (zero == 0) {
        a_changed_rows_[j] = changed;
        n = old_end;
        continue;
      }
    }
    if (same) ++listing_generation_;  // the forward pass's recorded updates name the entries
    same = false;  // this step and every later one are listed anew
    a_changed_rows_[j] = ~std::uint64_t{0};
    std::uint64_t* dependents = &a_dependents_[static_cast<std::size_t>(j) * ns_];
    std::fill_n(dependents, ns_, 0);
    for (int k = 0; k < ns_; ++k) {
      a_row_begin_[j * ns_ + k] = n;
      for (int l = 0; l < ns_; ++l) {
        const double v = A[l * ns_ + k];
        if (v == 0.0) continue;
        a_offsets_[n] = l * ns_ + k;
        a_row_bits_[n] = std::uint64_t{1} << (k & 63);
        a_entries_[n++] = Entry{k, l, v};
        dependents[l] |= std::uint64_t{1} << (k & 63);
      }
    }
  }
  if (!same) {
    std::fill(a_pattern_.begin(), a_pattern_.end(), 0);
    for (int e = 0; e < n; ++e) a_pattern_[a_entries_[e].row * ns_ + a_entries_[e].col] = 1;
  }
  a_row_begin_[static_cast<std::size_t>(np_) * ns_] = n;
  // C and the B_j are listed anew; a row that lists other entries than last time changed.
  int c_count = 0;
  c_changed_ = false;
  for (int k = 0; k < ny_; ++k) {
    c_changed_ = c_changed_ || c_row_begin_[k] != c_count;
    c_row_begin_[k] = c_count;
    std::uint64_t sources = 0;
    for (int l = 0; l < ns_; ++l) {
      if (d.C(k, l) == 0.0) continue;
      const Entry entry{k, l, d.C(k, l)};
      c_changed_ = c_changed_ || c_count >= c_count_ || c_entries_[c_count] != entry;
      c_entries_[c_count++] = entry;
      sources |= std::uint64_t{1} << (l & 63);
    }
    c_sources_[k] = sources;
  }
  c_changed_ = c_changed_ || c_count != c_count_;
  c_count_ = c_count;
  c_row_begin_[ny_] = c_count_;
  c_one_per_row_ = true;
  for (int k = 0; k < ny_; ++k) c_one_per_row_ = c_one_per_row_ && c_row_begin_[k + 1] == k + 1;
  // The nonzeros of the B_j of the moves (j < Nc), listed by row. A plant's B_j rarely change
  // (the UAV's are constant): compared as bits with the copy listed last time, unchanged B_j
  // keep their listing, and their rows count as unchanged.
  const std::size_t b_size = static_cast<std::size_t>(ns_) * nu_;
  bool b_same = b_listed_;
  for (int j = 0; j < nc_ && b_same; ++j) {
    b_same = std::memcmp(d.B[j].data(), &b_copy_[j * b_size], b_size * sizeof(double)) == 0;
  }
  if (b_same) {
    std::fill(b_changed_rows_.begin(), b_changed_rows_.end(), 0);
  } else {
    list_b_nonzeros();
    ++listing_generation_;
  }
  if (c_changed_) ++listing_generation_;
  // The reach of each state (bit c: some move of input c changes it at some step): the
  // inputs of its B rows, closed over the union pattern of the A_j. Outside its reach a row of
  // Γ is zero at every step, and so is an output's row of Φ outside the union of the reaches
  // its C row reads. With B, the pattern and C as last time, the reaches are too.
  if (b_same && same && !c_changed_) return;
  state_reach_ = b_reach_;
  for (bool changed = true; changed;) {
    changed = false;
    for (int k = 0; k < ns_; ++k) {
      for (int l = 0; l < ns_; ++l) {
        if (a_pattern_[k * ns_ + l] != 0 && (state_reach_[l] & ~state_reach_[k]) != 0) {
          state_reach_[k] |= state_reach_[l];
          changed = true;
        }
      }
    }
  }
  std::fill(output_reach_.begin(), output_reach_.end(), 0);
  for (int e = 0; e < c_count_; ++e) {
    output_reach_[c_entries_[e].row] |= state_reach_[c_entries_[e].col];
  }
  const auto span = [this](std::uint64_t reach, int& lo, int& hi) {
    lo = reach == 0 ? 0 : std::countr_zero(reach) * nc_;
    hi = reach == 0 ? 0 : static_cast<int>(std::bit_width(reach)) * nc_;
  };
  for (int k = 0; k < ns_; ++k) span(state_reach_[k], state_span_lo_[k], state_span_hi_[k]);
  for (int k = 0; k < ny_; ++k) span(output_reach_[k], output_span_lo_[k], output_span_hi_[k]);
}

void IncrementalMpc::list_b_nonzeros() {
  const IncrementalMpcData& d = data_;
  const std::size_t b_size = static_cast<std::size_t>(ns_) * nu_;
  std::fill(b_reach_.begin(), b_reach_.end(), 0);
  int nb = 0;
  for (int j = 0; j < nc_; ++j) {
    const MatX& B = d.B[j];
    std::memcpy(&b_copy_[j * b_size], B.data(), b_size * sizeof(double));
    b_changed_rows_[j] = 0;
    for (int k = 0; k < ns_; ++k) {
      const int row = j * ns_ + k;
      const int old_begin = b_row_begin_[row], old_end = b_row_begin_[row + 1];
      bool changed = !b_listed_ || old_begin != nb;
      b_row_begin_[row] = nb;
      for (int c = 0; c < nu_; ++c) {
        const double v = B(k, c);
        if (v == 0.0) continue;
        const Entry entry{k, c, v};
        changed = changed || nb >= old_end || b_entries_[nb] != entry;
        b_entries_[nb++] = entry;
        b_reach_[k] |= std::uint64_t{1} << c;
      }
      if (changed || nb != old_end) b_changed_rows_[j] |= std::uint64_t{1} << (k & 63);
    }
  }
  b_row_begin_[nc_ * ns_] = nb;
  b_listed_ = true;
}

void IncrementalMpc::group_rows_by_span() {
  // Output components with the same span share build_cost's blocked rank updates.
  groups_ = 0;
  int n = 0;
  std::fill(output_group_.begin(), output_group_.end(), -1);
  for (int k = 0; k < ny_; ++k) {
    const int lo = output_span_lo_[k], hi = output_span_hi_[k];
    if (lo == hi) continue;  // an output no input moves: its rows of Φ are zero
    bool seen = false;
    for (int g = 0; g < groups_; ++g) {
      if (group_lo_[g] == lo && group_hi_[g] == hi) {
        seen = true;
        output_group_[k] = g;
      }
    }
    if (seen) continue;
    output_group_[k] = groups_;
    group_lo_[groups_] = lo;
    group_hi_[groups_] = hi;
    group_begin_[groups_] = n;
    for (int j = 0; j < np_; ++j) {
      for (int kk = k; kk < ny_; ++kk) {
        if (output_span_lo_[kk] == lo && output_span_hi_[kk] == hi) group_rows_[n++] = j * ny_ + kk;
      }
    }
    ++groups_;
  }
  group_begin_[groups_] = n;
  // Disjoint spans sum into separate blocks of H, so a group whose rows did not change keeps
  // its block; overlapping spans share entries, and every group is summed again.
  groups_disjoint_ = true;
  for (int g = 0; g < groups_; ++g) {
    for (int h = 0; h < g; ++h) {
      if (group_lo_[g] < group_hi_[h] && group_lo_[h] < group_hi_[g]) groups_disjoint_ = false;
    }
  }
  std::fill(group_stale_.begin(), group_stale_.end(), 1);
  h_valid_ = false;
}

void IncrementalMpc::build_prediction() {
  collect_plant_nonzeros();
  forward_pass();
}

const double* IncrementalMpc::known_term(int j, bool zero_increment) {
  // w_j = state offset + E_j·(forecast increment). The increment is usually zero after the first
  // step (a held measurement), and E·0 would add exact zeros: then w_j is the column of the
  // offsets itself, read in place. The solution's simulation reads the same terms again.
  const IncrementalMpcData& d = data_;
  if (zero_increment) return known_terms_[j] = d.state_offset.col(j).data();
  const double* increment = d.disturbance_delta.col(j).data();
  bool zero = true;
  for (int i = 0; i < nd_; ++i) zero = zero && increment[i] == 0.0;
  if (zero) return known_terms_[j] = d.state_offset.col(j).data();
  auto w = W_.col(j);
  w.noalias() = d.state_offset.col(j);
  w.noalias() += d.E[j].lazyProduct(d.disturbance_delta.col(j));
  return known_terms_[j] = w.data();
}

void IncrementalMpc::forward_pass() {
  const IncrementalMpcData& d = data_;
  // One forward pass (eq. 7–9) over the stage matrices. Γ holds ∂Δs_{j+1}/∂ΔU; the free
  // increment ds and output y are the same recursion with every move zero:
  //   Γ_j = A_j Γ_{j−1} + [B_j in the columns of move j],   Φ_j = Φ_{j−1} + C Γ_j,
  //   ds_j = A_j ds_{j−1} + w_j,                              y_j = y_{j−1} + C ds_j.
  // Γ and Φ are row-major with the columns ordered by input, then move (column c·Nc + i is
  // Δu_{k+i,c}): a row's part for one input is contiguous, and a row is nonzero only inside
  // its span, the contiguous run of columns from its first to its last reached input's
  // block, whose other entries are exact zeros. Every row of Γ_j and Φ_j is one fused loop
  // over its span, also before step Nc: Γ_{−1} = 0, so the columns of the moves not started
  // yet are sums of exact zeros (one loop without per-input branches costs less than
  // skipping them). The zeros outside a row's span hold because they are never written, and
  // Γ and Φ are cleared when a reach changes.
  //
  // Rows that do not change between steps are not computed again. A row of Γ_j keeps last
  // step's values when its row of A_j (and of B_j, for a move) is unchanged and so are the
  // rows of Γ_{j−1} it sums; a row of Φ_j likewise with C, Φ_{j−1} and the rows of Γ_j it
  // reads. The same sums of the same numbers give the same values, so a kept row is exactly
  // the one the pass would compute. For the UAV only the x and y rows depend on the nominal
  // heading and speed: the speed, turn-rate, climb-rate, heading and altitude rows of Γ and the
  // altitude rows of Φ are kept from the first step on.
  // The rows are tracked as bits of 64-bit masks; a plant of more than 64 states computes
  // every row each step.
  bool keep = rows_valid_ && ns_ <= 64;  // Γ's rows
  bool keep_phi = keep && !c_changed_;   // Φ's rows also read C
  if (output_reach_ != phi_reach_) {
    Phi_.setZero();
    phi_reach_ = output_reach_;
    group_rows_by_span();
    keep_phi = false;
  }
  if (state_reach_ != gamma_reach_) {
    Gamma_.setZero();  // block 0, Γ_{−1}, stays zero
    gamma_reach_ = state_reach_;
    keep = false;
    keep_phi = false;
  }
  const std::uint64_t all = ~std::uint64_t{0};
  std::uint64_t previous_changed = 0;  // rows of Γ_{j−1} computed anew (Γ_{−1} = 0 never is)
  int rows_computed = 0;
  const std::uint64_t state_rows = ns_ >= 64 ? all : (std::uint64_t{1} << ns_) - 1;
  // The rows whose own row of A_j changed at every step (the UAV's x and y) are computed at
  // every step anyway and need no history: they alternate between two blocks of Γ, so that the
  // pass touches two rows of theirs, not one a step (a history touched each step is memory the
  // QP's data would otherwise keep in the cache). A row with no history from the last pass is
  // computed at every step of this one.
  std::uint64_t alternating = 0;
  if (keep) {
    alternating = state_rows;
    for (int j = 0; j < np_; ++j) alternating &= a_changed_rows_[j];
  }
  const std::uint64_t no_history = keep ? ~history_valid_ & state_rows : all;
  // Which rows a pass computes, and from which rows and coefficients, follows from the masks
  // below, the listings of the plant's nonzeros and the reaches alone. When they are what they
  // were at the last pass, this pass replays its row updates as recorded (the same sums of the
  // same rows, with the coefficients' present values) instead of deciding them again row by
  // row; for the UAV every step after the first few (the x and y rows of every step).
  const bool steady = keep && keep_phi;
  const bool replay = steady && updates_.valid && updates_.listing == listing_generation_ &&
                      updates_.alternating == alternating && updates_.no_history == no_history &&
                      updates_.a_changed == a_changed_rows_ &&
                      updates_.b_changed == b_changed_rows_;
  bool record = steady && !replay;
  if (!replay) {
    updates_.gamma.clear();
    updates_.phi.clear();
  }
  // The free increments ds_{j−1} and ds_j, in the two buffers by turns.
  double* ds = ds_.data();
  double* dsn = dsn_.data();
  std::copy_n(d.delta_state.data(), ns_, ds);
  y_ = d.output;
  // The forecast increments after the first step, all zero for a held measurement: one count
  // for all of them instead of a test a step.
  const bool later_increments_zero =
      count_nonzeros(d.disturbance_delta.data() + nd_, nd_ * (np_ - 1)) == 0;
  // Γ is stored by state, then block: state k of block b is row k·(Np + 3) + b, so a kept row's
  // values for every step (read one after the other by the rows that change at every step) are
  // one contiguous run, not one row in every block's n_s. A block's rows are `ld` apart.
  const Eigen::Index ld = static_cast<Eigen::Index>(np_ + 3) * Gamma_.outerStride();
  // Block b of Γ: its state 0's row.
  const auto block = [&](int b) { return Gamma_.data() + b * Gamma_.outerStride(); };
  // A row of Γ_j for a move (j < Nc) gets B_j's entries in the columns of move j, where Γ_{j−1}
  // is zero, after its sum (none for other rows: b_begin = b_end).
  const auto write_b_entries = [&](const RowUpdate& update, int j) __attribute__((always_inline)) {
    for (int e = update.b_begin; e < update.b_end; ++e) {
      update.row[b_entries_[e].col * nc_ + j] = b_entries_[e].value;
    }
  };
  // A row update: its sum, then B_j's entries.
  const auto apply_update = [&](const RowUpdate& update, int j) __attribute__((always_inline)) {
    double a[kMaxRowTerms];
    for (int t = 0; t < update.count; ++t) a[t] = *update.coefficient[t];
    combine_row(update.target, update.size, update.base, a, update.source, update.count);
    write_b_entries(update, j);
  };
  // A row update decided now: its terms (one row of A_j's or C's listing) read rows of the
  // block at `from` (`from_alt` for the alternating rows) at the row's span, from column lo;
  // made, and recorded into `recorded` for the next pass. A row of more than kMaxRowTerms terms
  // is summed term by term and not recorded (the next pass decides again).
  const auto decide = [&](RowUpdate update, const Entry* terms, const double* from,
                          const double* from_alt, int lo, std::vector<RowUpdate>& recorded, int j)
      __attribute__((always_inline)) {
    const auto source = [&](int col) {
      return ((alternating >> (col & 63)) & 1 ? from_alt : from) + col * ld + lo;
    };
    if (update.count <= kMaxRowTerms) {
      for (int t = 0; t < update.count; ++t) {
        update.coefficient[t] = &terms[t].value;
        update.source[t] = source(terms[t].col);
      }
      apply_update(update, j);
      if (record) recorded.push_back(update);
      return;
    }
    record = false;
    if (update.base == nullptr) {
      std::fill_n(update.target, update.size, 0.0);
    } else {
      std::copy_n(update.base, update.size, update.target);
    }
    for (int t = 0; t < update.count; ++t) {
      axpy(update.target, update.size, terms[t].value, source(terms[t].col));
    }
    write_b_entries(update, j);
  };
  for (int j = 0; j < np_; ++j) {
    const double* w = known_term(j, j > 0 && later_increments_zero);
    // Γ_{j−1}: its block (j), or the alternating block for the alternating rows (Γ_{−1} = 0,
    // block 0, for all at step 0); Γ_j's are the next ones.
    const double* previous = block(j);
    const double* previous_alt = j == 0 ? block(0) : block(np_ + 1 + ((j - 1) & 1));
    double* now = block(j + 1);
    double* now_alt = block(np_ + 1 + (j & 1));
    // The rows of Γ_j computed anew: every row without a kept pass; else the rows of A_j
    // (or B_j) that changed, and the rows that sum a changed row of Γ_{j−1}.
    std::uint64_t changed = keep ? a_changed_rows_[j] | no_history : all;
    if (j < nc_) changed |= b_changed_rows_[j];
    // The free increment ds_j = A_j ds_{j−1} + w_j.
    const int* row_begin = &a_row_begin_[static_cast<std::size_t>(j) * ns_];
    if (dense_) {
      dense_columns_product(d.A[j].data(), ns_, ns_, w, ds, dsn);
    } else {
      for (int k = 0; k < ns_; ++k) {
        double v = w[k];
        for (int e = row_begin[k]; e < row_begin[k + 1]; ++e) {
          v += a_entries_[e].value * ds[a_entries_[e].col];
        }
        dsn[k] = v;
      }
    }
    // Row k of Γ_j = Σ_l A_j(k, l)·(row l of Γ_{j−1}) over the row's span: a source row's
    // span lies inside it (reaches are closed over A), and its entries outside its own span
    // are exact zeros.
    if (replay) {
      for (int u = updates_.gamma_begin[j]; u < updates_.gamma_begin[j + 1]; ++u) {
        apply_update(updates_.gamma[u], j);
      }
    } else {
      updates_.gamma_begin[j] = static_cast<int>(updates_.gamma.size());
      const auto gamma_row = [&](int k) __attribute__((always_inline)) {
        const int first = row_begin[k], end = row_begin[k + 1];
        const int lo = state_span_lo_[k];
        double* row = ((alternating >> (k & 63)) & 1 ? now_alt : now) + k * ld;
        RowUpdate update{row,
                         row + lo,
                         nullptr,
                         {},
                         {},
                         state_span_hi_[k] - lo,
                         end - first,
                         j < nc_ ? b_row_begin_[j * ns_ + k] : 0,
                         j < nc_ ? b_row_begin_[j * ns_ + k + 1] : 0,
                         -1,
                         -1};
        decide(update, &a_entries_[first], previous, previous_alt, lo, updates_.gamma, j);
      };
      if (ns_ <= 64) {
        // And the rows that read a row of Γ_{j−1} computed anew (its dependents in A_j); only
        // the rows computed anew are visited.
        const std::uint64_t* dependents = &a_dependents_[static_cast<std::size_t>(j) * ns_];
        for (std::uint64_t m = previous_changed; m != 0; m &= m - 1) {
          changed |= dependents[std::countr_zero(m)];
        }
        changed &= state_rows;
        for (std::uint64_t m = changed; m != 0; m &= m - 1) gamma_row(std::countr_zero(m));
        rows_computed += std::popcount(changed);
      } else {
        for (int k = 0; k < ns_; ++k) gamma_row(k);
        rows_computed += ns_;
      }
      previous_changed = changed;
    }
    std::swap(ds, dsn);
    // y_j = y_{j−1} + C ds_j row by row in scalars, over C's few nonzeros (one a row: the
    // same sum without the loop).
    if (c_one_per_row_) {
      for (int k = 0; k < ny_; ++k) {
        const double v = y_[k] + c_entries_[k].value * ds[c_entries_[k].col];
        y_[k] = v;
        Yfree_[j * ny_ + k] = v;
      }
    } else {
      for (int k = 0; k < ny_; ++k) {
        double v = y_[k];
        for (int ec = c_row_begin_[k]; ec < c_row_begin_[k + 1]; ++ec) {
          v += c_entries_[ec].value * ds[c_entries_[ec].col];
        }
        y_[k] = v;
        Yfree_[j * ny_ + k] = v;
      }
    }
    // Row k of Φ_j = row k of Φ_{j−1} + Σ_l C(k, l)·(row l of Γ_j), over the output's span.
    if (replay) {
      for (int u = updates_.phi_begin[j]; u < updates_.phi_begin[j + 1]; ++u) {
        const RowUpdate& update = updates_.phi[u];
        apply_update(update, j);
        range_stale_[update.phi_row] = 1;
        if (update.group >= 0) group_stale_[update.group] = 1;
      }
      continue;
    }
    updates_.phi_begin[j] = static_cast<int>(updates_.phi.size());
    for (int k = 0; k < ny_; ++k) {
      const int first = c_row_begin_[k], end = c_row_begin_[k + 1];
      const int r = j * ny_ + k;
      const bool row_changed = !keep_phi || (j > 0 && phi_changed_[r - ny_] != 0) ||
                               (c_sources_[k] & previous_changed) != 0;
      phi_changed_[r] = row_changed ? 1 : 0;
      if (!row_changed) continue;
      ++rows_computed;
      range_stale_[r] = 1;
      if (output_group_[k] >= 0) group_stale_[output_group_[k]] = 1;
      const int lo = output_span_lo_[k];
      double* row = Phi_.row(r).data();
      RowUpdate update{row,
                       row + lo,
                       j > 0 ? Phi_.row(r - ny_).data() + lo : nullptr,
                       {},
                       {},
                       output_span_hi_[k] - lo,
                       end - first,
                       0,
                       0,
                       r,
                       output_group_[k]};
      decide(update, &c_entries_[first], now, now_alt, lo, updates_.phi, j);
    }
  }
  if (replay) {
    rows_computed = updates_.rows_computed;
  } else {
    updates_.gamma_begin[np_] = static_cast<int>(updates_.gamma.size());
    updates_.phi_begin[np_] = static_cast<int>(updates_.phi.size());
    updates_.valid = record;
    updates_.listing = listing_generation_;
    updates_.alternating = alternating;
    updates_.no_history = no_history;
    updates_.a_changed = a_changed_rows_;
    updates_.b_changed = b_changed_rows_;
    updates_.rows_computed = rows_computed;
  }
  rows_valid_ = true;
  history_valid_ = ~alternating & state_rows;
  result_.prediction_rows_computed = rows_computed;
  result_.prediction_replayed = replay;
}

void IncrementalMpc::build_cost() {
  const IncrementalMpcData& d = data_;
  const int nU = nc_ * nu_;
  // Cost (eq. 10): H_uu = 2(ΦᵀQ̄Φ + R̄), f_u = −2ΦᵀQ̄(R − Y_free). Q̄ is diagonal, so
  // ΦᵀQ̄Φ = Σ_r q_r φ_r φ_rᵀ over the rows r of Φ, and a row is nonzero only inside its
  // output's span: for the UAV the x and y rows in the 20 columns of the speed and turn
  // moves, the z rows in the 10 of the climb moves (a third of the flops of the dense
  // product). The lower triangle of a span is summed in 4 × 8 and 4 × 4 tiles, each tile's
  // sums kept in vector registers over all the rows of the span and stored once; the columns
  // past the last multiple of four are summed entry by entry. Sums run in Φ's column order,
  // which is the QP's.
  //
  // A group none of whose rows of Φ changed since its block was summed keeps its block of H
  // (the UAV's altitude rows: the climb block); f depends on the reference and the free
  // response and is summed every step.
  const bool by_block = h_valid_ && groups_disjoint_;
  if (!by_block) Hp_.setZero();
  fp_.setZero();
  const Eigen::Index ld = Phi_.outerStride();
  const double* phi = Phi_.data();
  const Eigen::Index hld = Hp_.outerStride();
  for (int g = 0; g < groups_; ++g) {
    const int lo = group_lo_[g], size = group_hi_[g] - lo;
    const int full = size / 4 * 4;  // columns in whole tiles
    const int begin = group_begin_[g], end = group_begin_[g + 1];
    const int* rows = group_rows_.data();
    double* f = fp_.data() + lo;
    const double* reference = d.reference.data();  // column-major n_y×Np: entry r is row r's
    // Each row's start in Φ (at the span) and its weight in f_u.
    const int count = end - begin;
    const double** starts = row_starts_.data();
    double* weights = gradient_weights_.data();
    for (int n = 0; n < count; ++n) {
      const int r = rows[begin + n];
      starts[n] = phi + r * ld + lo;
      weights[n] = -2.0 * qdiag_[r] * (reference[r] - Yfree_[r]);
    }
    add_weighted_rows(f, size, starts, weights, count);
    if (by_block && group_stale_[g] == 0) continue;
    group_stale_[g] = 0;
    if (by_block) {
      // The whole block: the diagonal tiles also sum entries above the diagonal (unread).
      for (int a = lo; a < lo + size; ++a) std::fill_n(Hp_.row(a).data() + lo, size, 0.0);
    }
    // Each row's entries times q_r packed one row after the other (from the starts found
    // above): the tiles below read a row's four products q_r·φ_r(a0 + i) as broadcasts from
    // memory instead of four loads and four multiplications a tile (the same products, so the
    // same sums).
    double* scaled = scaled_rows_.data();
    for (int n = 0; n < count; ++n)
      scale4(scaled + n * size, size, qdiag_[rows[begin + n]], starts[n]);
    for (int a0 = 0; a0 < full; a0 += 4) {
      int b0 = 0;
      for (; b0 + 8 <= a0 + 4; b0 += 8) {
        // A 4 × 8 tile: acc_i = Σ_r q_r φ_r(a0 + i) φ_r(b0 .. b0 + 7), eight independent sums
        // (the latency of one fused multiply-add chain would bound four).
        Vec4 lo0 = {}, lo1 = {}, lo2 = {}, lo3 = {}, hi0 = {}, hi1 = {}, hi2 = {}, hi3 = {};
        const double* c = scaled + a0;
        for (int n = 0; n < count; ++n, c += size) {
          const double* p = starts[n];
          Vec4 pl, ph;
          std::memcpy(&pl, p + b0, sizeof pl);
          std::memcpy(&ph, p + b0 + 4, sizeof ph);
          lo0 += c[0] * pl;
          hi0 += c[0] * ph;
          lo1 += c[1] * pl;
          hi1 += c[1] * ph;
          lo2 += c[2] * pl;
          hi2 += c[2] * ph;
          lo3 += c[3] * pl;
          hi3 += c[3] * ph;
        }
        const Vec4* acc[4][2] = {{&lo0, &hi0}, {&lo1, &hi1}, {&lo2, &hi2}, {&lo3, &hi3}};
        for (int i = 0; i < 4; ++i) {
          double* h = Hp_.data() + (lo + a0 + i) * hld + lo + b0;
          for (int j = 0; j < 4; ++j) h[j] += (*acc[i][0])[j];
          for (int j = 0; j < 4; ++j) h[4 + j] += (*acc[i][1])[j];
        }
      }
      for (; b0 <= a0; b0 += 4) {
        // A 4 × 4 tile: acc_i[j] = Σ_r q_r φ_r(a0 + i) φ_r(b0 + j).
        Vec4 acc0 = {}, acc1 = {}, acc2 = {}, acc3 = {};
        const double* c = scaled + a0;
        for (int n = 0; n < count; ++n, c += size) {
          Vec4 pb;
          std::memcpy(&pb, starts[n] + b0, sizeof pb);
          acc0 += c[0] * pb;
          acc1 += c[1] * pb;
          acc2 += c[2] * pb;
          acc3 += c[3] * pb;
        }
        const Vec4* acc[4] = {&acc0, &acc1, &acc2, &acc3};
        for (int i = 0; i < 4; ++i) {
          double* h = Hp_.data() + (lo + a0 + i) * hld + lo + b0;
          for (int j = 0; j < 4; ++j) h[j] += (*acc[i])[j];
        }
      }
    }
    for (int a = full; a < size; ++a) {  // the rows of the triangle below the last tile
      double* h = Hp_.data() + (lo + a) * hld + lo;
      for (int n = 0; n < count; ++n) {
        const double* p = starts[n];
        const double c = scaled[n * size + a];
        for (int b = 0; b <= a; ++b) h[b] += c * p[b];
      }
    }
    if (by_block) write_hessian_block(lo, lo + size);
  }
  // The QP orders ΔU as Φ does (input, then move): H is Hp_ doubled and made symmetric plus
  // 2R̄, f is fp_ (by block above, H's other entries keep their values).
  qp_.f.head(nU) = fp_;
  if (!by_block) write_hessian_block(0, nU);
  h_valid_ = true;
}

void IncrementalMpc::write_hessian_block(int lo, int hi) {
  // H = 2·Hp_ made symmetric, plus 2R̄ on the diagonal, over the block [lo, hi)². H is
  // column-major, Hp_ row-major with its lower triangle (a ≥ b) valid. Column b of H below the
  // diagonal is column b of that triangle, strided in Hp_: read as 4 × 4 tiles of its rows and
  // transposed in registers, each tile's columns stored whole. Above the diagonal, column b of
  // H is row b of the triangle, contiguous. Doubling is exact, so the values are the entries'.
  double* H = qp_.H.data();
  const Eigen::Index ldh = qp_.H.outerStride(), ld = Hp_.outerStride();
  const double* P = Hp_.data();
  const int size = hi - lo, full = size / 4 * 4;
  const Vec4 two = {2.0, 2.0, 2.0, 2.0};
  for (int a0 = 0; a0 < full; a0 += 4) {
    const double* rows = P + (lo + a0) * ld + lo;
    for (int b0 = 0; b0 <= a0; b0 += 4) {
      // A tile on the diagonal also carries entries above it, which the loop below rewrites.
      Vec4 r0, r1, r2, r3;
      std::memcpy(&r0, rows + b0, sizeof r0);
      std::memcpy(&r1, rows + ld + b0, sizeof r1);
      std::memcpy(&r2, rows + 2 * ld + b0, sizeof r2);
      std::memcpy(&r3, rows + 3 * ld + b0, sizeof r3);
      transpose4(r0, r1, r2, r3);  // now columns b0 … b0 + 3, rows a0 … a0 + 3
      r0 *= two;
      r1 *= two;
      r2 *= two;
      r3 *= two;
      double* out = H + (lo + b0) * ldh + lo + a0;
      std::memcpy(out, &r0, sizeof r0);
      std::memcpy(out + ldh, &r1, sizeof r1);
      std::memcpy(out + 2 * ldh, &r2, sizeof r2);
      std::memcpy(out + 3 * ldh, &r3, sizeof r3);
    }
  }
  for (int a = lo + full; a < hi; ++a) {  // the rows below the last whole tile
    for (int b = lo; b <= a; ++b) H[b * ldh + a] = 2.0 * P[a * ld + b];
  }
  for (int b = lo; b < hi; ++b) {
    double* out = H + b * ldh;
    const double* hb = P + b * ld;
    for (int a = lo; a < b; ++a) out[a] = 2.0 * hb[a];
    out[b] += 2.0 * options_.move_weight[b / nc_];
  }
}

void IncrementalMpc::resize_soft_rows(int needed) {
  // The QP carries the soft rows in blocks of kSoftRowBlock, padded with rows whose sides are
  // both infinite, and keeps the largest number of blocks it has needed: its size (and so the
  // solver's workspace and warm start) changes only when the rows a step carries exceed every
  // step's before, at most once a block. The count of rows not redundant wavers from step to
  // step, and a QP that followed it down would allocate again on its way back up.
  const int cap = dims_.soft_row_capacity;
  const int blocks = (needed + kSoftRowBlock - 1) / kSoftRowBlock;
  const int wanted = std::min(cap, blocks * kSoftRowBlock);
  if (wanted <= soft_rows_in_qp_) return;
  const int old_m = soft_rows_begin_ + soft_rows_in_qp_;
  soft_rows_in_qp_ = wanted;
  const int m = soft_rows_begin_ + wanted;
  qp_.G.conservativeResize(m, nz_);  // keeps the constant input-limit rows at the top
  qp_.lg.conservativeResize(m);
  qp_.ug.conservativeResize(m);
  // The new rows are padding until written: both sides infinite (a soft row's upper side
  // stays so).
  qp_.G.bottomRows(m - old_m).setZero();
  qp_.lg.tail(m - old_m).setConstant(-qp::kInfinity);
  qp_.ug.tail(m - old_m).setConstant(qp::kInfinity);
}

void IncrementalMpc::assemble_qp() {
  const IncrementalMpcData& d = data_;
  // Move bounds Δu_min ≤ Δu ≤ Δu_max (box); slack bounds σ ≥ 0 stay as built.
  // Variables and input rows in the QP's order (input, then move: index c·Nc + i).
  // The inputs whose move box changed (bit c: input c), for the ranges of assemble_soft_rows.
  box_changed_ = 0;
  for (int c = 0; c < nu_; ++c) {
    for (int i = 0; i < nc_; ++i) {
      const int q = c * nc_ + i;
      const bool same =
          std::bit_cast<std::uint64_t>(qp_.lb[q]) ==
              std::bit_cast<std::uint64_t>(d.move_min(c, i)) &&
          std::bit_cast<std::uint64_t>(qp_.ub[q]) == std::bit_cast<std::uint64_t>(d.move_max(c, i));
      if (!same) box_changed_ |= std::uint64_t{1} << c;
      qp_.lb[q] = d.move_min(c, i);
      qp_.ub[q] = d.move_max(c, i);
      // Input limits: u_min − u_{k−1} ≤ Σ Δu ≤ u_max − u_{k−1}.
      qp_.lg[input_rows_begin_ + q] = d.input_min(c, i) - d.previous_input[c];
      qp_.ug[input_rows_begin_ + q] = d.input_max(c, i) - d.previous_input[c];
    }
  }
  if (box_changed_ != 0) {
    const int n = nc_ * nu_;
    box_regular_ = qp_.lb.head(n).allFinite() && qp_.ub.head(n).allFinite() &&
                   (qp_.lb.head(n).array() <= qp_.ub.head(n).array()).all();
    box_symmetric_ = box_regular_ && (qp_.lb.head(n).array() == -qp_.ub.head(n).array()).all();
  }
  if (options_.hard_output_limits) {
    for (int q = 0; q < nc_ * nu_; ++q) {
      qp_.G.col(q).segment(output_rows_begin_, np_ * ny_) = Phi_.col(q);
    }
    for (int j = 0; j < np_; ++j) {
      const auto yf = Yfree_.segment(j * ny_, ny_);
      qp_.lg.segment(output_rows_begin_ + j * ny_, ny_) = d.output_min.col(j) - yf;
      qp_.ug.segment(output_rows_begin_ + j * ny_, ny_) = d.output_max.col(j) - yf;
    }
  }
}

void IncrementalMpc::assemble_soft_rows() {
  const IncrementalMpcData& d = data_;
  const int nU = nc_ * nu_;
  // Soft rows: aᵀ(Y_free,j + Φ_j ΔU) + σ_g ≥ b  ⇔  aᵀΦ_j ΔU + σ_g ≥ b − aᵀY_free,j. Φ_j is
  // zero right of the moves started by step j and outside the reaches of the outputs a reads.
  //
  // Redundant rows are left out of the QP. The move bounds are a box, so the least value of
  // aᵀΦ_j ΔU any feasible ΔU can give is bounded below by Σ_k a_k·(min or max of φ_{j,k}ᵀΔU
  // over the box), and a row whose bound lies below that is met by every feasible point
  // (σ ≥ 0): it cannot be active, and leaving it out changes neither the feasible set nor the
  // (unique) solution. Most rows are of this kind — a terrain or threat row within the
  // activation distance but farther than the moves can carry the UAV in its horizon (70–80 %
  // of the rows in `bench mpc` and the default mission) — and each one left out is a row the
  // QP neither stores, nor checks, nor carries in its working set.
  //
  // A row's range is computed again only if the row or the box over its inputs changed.
  const Eigen::Index ld = Phi_.outerStride();
  for (int r = 0, k = 0; r < np_ * ny_ && options_.drop_redundant_soft_rows;
       ++r, k = k + 1 == ny_ ? 0 : k + 1) {  // k = r mod n_y, the row's output
    if (range_stale_[r] == 0 && (box_changed_ & output_reach_[k]) == 0) continue;
    range_stale_[r] = 0;
    const int lo = output_span_lo_[k], size = output_span_hi_[k] - lo;
    const double* p = Phi_.data() + r * ld + lo;
    const double* bl = qp_.lb.data() + lo;  // the move box, in Φ's column order too
    const double* bh = qp_.ub.data() + lo;
    // Four partial sums a side (a bound, so the order of the sums does not matter); a zero
    // entry adds zero even against an infinite bound, and a NaN propagates (its row is kept).
    // In a finite box with l ≤ h (box_regular_) the smaller of v·l and v·h is the lower end
    // whatever v's sign, and a zero v gives a zero either way, so two comparisons and blends a
    // side become one min or max. A NaN v propagates (both products are NaN, and each picks
    // its second operand when unordered); an infinite v against a zero side gives one NaN
    // product, and the other one is taken (±∞ instead of NaN: the row is kept either way, its
    // scale not finite, and the QP is rejected for Φ's infinite entries).
    if (box_symmetric_) {
      // l = −h (h ≥ 0): v·l = −(v·h) exactly, so the ends are ∓Σ|v|·h, one sum instead of
      // two (the loop below's sums up to their round-off, which the margin of keep_rows
      // covers).
      Vec4 acc = {};
      int q = 0;
      for (; q + 4 <= size; q += 4) {
        Vec4 v, h;
        std::memcpy(&v, p + q, sizeof v);
        std::memcpy(&h, bh + q, sizeof h);
        make_magnitude(v);
        acc += v * h;
      }
      double sum = acc[0] + acc[1] + acc[2] + acc[3];
      for (; q < size; ++q) sum += std::abs(p[q]) * bh[q];
      phi_min_[r] = -sum;
      phi_max_[r] = sum;
      continue;
    }
    Vec4 mn = {}, mx = {};
    const Vec4 zero = {};
    int q = 0;
    for (; q + 4 <= size; q += 4) {
      Vec4 v, l, h;
      std::memcpy(&v, p + q, sizeof v);
      std::memcpy(&l, bl + q, sizeof l);
      std::memcpy(&h, bh + q, sizeof h);
      const Vec4 vl = v * l, vh = v * h;
      if (box_regular_) {  // the same each pass: the compiler makes two loops of it
        mn += vl < vh ? vl : vh;
        mx += vl > vh ? vl : vh;
      } else {
        mn += v == zero ? zero : (v > zero ? vl : vh);
        mx += v == zero ? zero : (v > zero ? vh : vl);
      }
    }
    double row_min = mn[0] + mn[1] + mn[2] + mn[3];
    double row_max = mx[0] + mx[1] + mx[2] + mx[3];
    for (; q < size; ++q) {
      const double v = p[q];
      if (v == 0.0) continue;
      if (v > 0.0) {
        row_min += v * bl[q];
        row_max += v * bh[q];
      } else {  // negative, or NaN (propagated)
        row_min += v * bh[q];
        row_max += v * bl[q];
      }
    }
    phi_min_[r] = row_min;
    phi_max_[r] = row_max;
  }
  // The rows that can be violated. `outputs` is n_y, a constant for the UAV's three outputs
  // (the loop over a row's terms then unrolls).
  const auto keep_rows = [&](const int outputs) __attribute__((always_inline)) {
    kept_count_ = 0;
    const double* normals = d.soft_normal.data();  // column-major n_y×capacity
    for (int r = 0; r < d.soft_row_count; ++r) {
      const int j = d.soft_step[r];
      double bound = d.soft_bound[r];
      double lowest = 0.0;  // ≤ min of aᵀΦ_j ΔU over the box
      double scale = 1.0;   // of the terms summed, for the margin below
      for (int k = 0; k < outputs; ++k) {
        const double a = normals[r * outputs + k];
        if (a == 0.0) continue;
        const double free = a * Yfree_[j * outputs + k];
        const double lo = phi_min_[j * outputs + k], hi = phi_max_[j * outputs + k];
        bound -= free;
        lowest += a * (a > 0.0 ? lo : hi);
        scale += std::abs(free) + std::abs(a) * std::max(std::abs(lo), std::abs(hi));
      }
      // The margin keeps a row whose redundancy is within the sums' round-off.
      if (options_.drop_redundant_soft_rows &&
          lowest - bound > 1e-9 * (scale + std::abs(d.soft_bound[r]))) {
        continue;
      }
      kept_rows_[kept_count_] = r;
      kept_bounds_[kept_count_++] = bound;
    }
  };
  if (ny_ == 3) {
    keep_rows(3);
  } else {
    keep_rows(ny_);
  }

  resize_soft_rows(kept_count_);
  // Each kept row aᵀΦ_j is summed contiguously in Φ's column order into a row of soft_block_
  // (vector loops); G is column-major, so the block is then moved column by column, each
  // QP column a contiguous run of G, the slack columns last.
  // (`outputs` is n_y, a constant for the UAV's three, as in keep_rows.)
  const auto sum_kept_rows = [&](const int outputs) __attribute__((always_inline)) {
    const double* normals = d.soft_normal.data();
    for (int s = 0; s < kept_count_; ++s) {
      const int r = kept_rows_[s];
      const int j = d.soft_step[r];
      // The rows of Φ_j the soft row reads (a_k ≠ 0). Φ_j's entries outside a reach or right of
      // the moves started by step j are exact zeros, so every entry of the soft row can sum all
      // of them.
      constexpr int kTerms = 4;
      const double* rows[kTerms] = {};
      double coef[kTerms] = {};
      int terms = 0;
      for (int k = 0; k < outputs; ++k) {
        const double a = normals[r * outputs + k];
        if (a == 0.0) continue;
        if (terms < kTerms) rows[terms] = Phi_.row(j * outputs + k).data();
        if (terms < kTerms) coef[terms] = a;
        ++terms;
      }
      double* __restrict row = soft_block_.row(s).data();
      if (terms == 3) {  // the UAV's threat, neighbour and sloped terrain rows
        const double c0 = coef[0], c1 = coef[1], c2 = coef[2];
        const double* __restrict r0 = rows[0];
        const double* __restrict r1 = rows[1];
        const double* __restrict r2 = rows[2];
        for (int p = 0; p < nU; ++p) row[p] = c0 * r0[p] + c1 * r1[p] + c2 * r2[p];
      } else if (terms == 1) {  // level terrain
        scale4(row, nU, coef[0], rows[0]);
      } else if (terms == 2) {  // a threat or neighbour at the nominal's altitude
        scale4(row, nU, coef[0], rows[0]);
        axpy4(row, nU, coef[1], rows[1]);
      } else if (terms <= kTerms) {
        std::fill_n(row, nU, 0.0);
        for (int t = 0; t < terms; ++t) axpy(row, nU, coef[t], rows[t]);
      } else {
        std::fill_n(row, nU, 0.0);
        for (int k = 0; k < outputs; ++k) {
          const double a = normals[r * outputs + k];
          if (a == 0.0) continue;
          const int lo = output_span_lo_[k];
          axpy(row + lo, output_span_hi_[k] - lo, a, Phi_.row(j * outputs + k).data() + lo);
        }
      }
    }
  };
  if (ny_ == 3) {
    sum_kept_rows(3);
  } else {
    sum_kept_rows(ny_);
  }
  const int first = soft_rows_begin_, kept = kept_count_;
  // Padding rows that held a soft row last time (previous_count_ of them lead the QP's soft
  // rows) are cleared; the others stay clear.
  const int stale = std::max(previous_count_ - kept, 0);
  transpose(soft_block_.data(), soft_block_.outerStride(), kept, nU, qp_.G.data() + first,
            qp_.G.outerStride());
  for (int q = 0; q < nU; ++q) std::fill_n(qp_.G.col(q).data() + first + kept, stale, 0.0);
  for (int g = 0; g < ng_; ++g) {
    double* column = qp_.G.col(nU + g).data() + first;
    for (int s = 0; s < kept; ++s) column[s] = d.soft_group[kept_rows_[s]] == g ? 1.0 : 0.0;
    std::fill_n(column + kept, stale, 0.0);
  }
  qp_.lg.segment(first, kept) = kept_bounds_.head(kept);
  qp_.lg.segment(first + kept, stale).setConstant(-qp::kInfinity);
}

void IncrementalMpc::renumber_soft_rows(int old_soft_rows_in_qp) {
  // The soft rows come and go along the horizon (a threat's rows start at the first step at
  // which its nominal distance falls below the activation distance, a row leaves the QP when
  // it becomes redundant), and each one that comes or goes shifts the QP rows of all that
  // follow. The solver's hot start names its working set by row, so it would start from the
  // shifted rows' neighbours. Rows are matched by (group, source, step) instead: the same
  // constraint one control period later.
  const IncrementalMpcData& d = data_;
  const auto key = [&d](int r) {
    return SoftRowKey{d.soft_group[r], d.soft_source[r], d.soft_step[r]};
  };
  bool sorted = true;
  for (int s = 1; s < kept_count_ && sorted; ++s) {
    sorted = key(kept_rows_[s - 1]) < key(kept_rows_[s]);
  }
  const int old_rows = soft_rows_begin_ + old_soft_rows_in_qp;
  const int new_rows = soft_rows_begin_ + soft_rows_in_qp_;
  for (int i = 0; i < soft_rows_begin_; ++i) row_map_[i] = i;  // the input and output limits
  if (sorted && previous_sorted_) {
    std::fill(row_map_.begin() + soft_rows_begin_, row_map_.begin() + old_rows, -1);
    for (int o = 0, s = 0; o < previous_count_ && s < kept_count_;) {
      const SoftRowKey k = key(kept_rows_[s]);
      if (previous_keys_[o] < k) {
        ++o;
      } else if (k < previous_keys_[o]) {
        ++s;
      } else {
        row_map_[soft_rows_begin_ + o++] = soft_rows_begin_ + s++;
      }
    }
  } else {  // rows read by position, as if unchanged
    for (int i = soft_rows_begin_; i < old_rows; ++i) row_map_[i] = i < new_rows ? i : -1;
  }
  solver_.renumber_rows(std::span<const int>(row_map_.data(), old_rows));
  for (int s = 0; s < kept_count_; ++s) previous_keys_[s] = key(kept_rows_[s]);
  previous_count_ = kept_count_;
  previous_sorted_ = sorted;
}

void IncrementalMpc::extract_solution(const qp::QpResult& qp_result) {
  const IncrementalMpcData& d = data_;
  // Only a solved QP's moves are used; otherwise the result describes the zero-move plan
  // (inputs held), which is what a caller falls back to.
  const bool usable = qp_result.status == qp::QpStatus::kSolved && qp_result.z.size() == nz_ &&
                      qp_result.z.allFinite();
  if (usable) {
    for (int c = 0; c < nu_; ++c) {  // from the QP's order to the result's (move, then input)
      for (int i = 0; i < nc_; ++i) result_.moves[i * nu_ + c] = qp_result.z[c * nc_ + i];
    }
    result_.slack = qp_result.z.tail(ng_).cwiseMax(0.0);
  } else {
    result_.moves.setZero();
    result_.slack.setZero();
  }
  result_.first_move = result_.moves.head(nu_);
  result_.first_input = d.previous_input + result_.first_move;
  result_.max_slack = ng_ > 0 ? result_.slack.maxCoeff() : 0.0;

  // Predicted outputs and states under ΔU: step the augmented system (eq. 7) directly, over
  // whole columns of A_j and B_j for a plant of 4 to 8 states, else over the nonzeros listed by
  // build_prediction().
  double* ds = ds_.data();
  double* dsn = dsn_.data();
  std::copy_n(d.delta_state.data(), ns_, ds);
  double* s = result_.predicted_states.data();
  double* y = result_.predicted_outputs.data();
  const double* s_prev = d.state.data();
  const double* y_prev = d.output.data();
  double cost = 0.0;
  for (int j = 0; j < np_; ++j) {
    const double* w = known_terms_[j];  // as the forward pass of this solve found them
    const double* du = result_.moves.data() + j * nu_;
    const int* row_begin = &a_row_begin_[static_cast<std::size_t>(j) * ns_];
    const int* b_row_begin = j < nc_ ? &b_row_begin_[static_cast<std::size_t>(j) * ns_] : nullptr;
    if (dense_) {
      // A plant of 4 to 8 states over whole columns, as the forward pass: B_j Δu_j first (a
      // zero entry adds an exact zero), then w + it, then A_j ds in column order: the sums of
      // the loop below, term for term (the sign of an exact zero aside).
      double* v = dsn;
      if (j < nc_) {
        const double zero[kMaxDenseStates] = {};
        double bu[kMaxDenseStates];
        dense_columns_product(d.B[j].data(), ns_, nu_, zero, du, bu);
        for (int k = 0; k < ns_; ++k) bu[k] = w[k] + bu[k];
        dense_columns_product(d.A[j].data(), ns_, ns_, bu, ds, v);
      } else {
        dense_columns_product(d.A[j].data(), ns_, ns_, w, ds, v);
      }
      // s_j = s_{j−1} + ds_j as two four-lane sums, states 0–3 and the last four (overlapping
      // when n_s < 8: the same sums stored twice), as dense_columns_product loads its columns.
      const int tail = ns_ - 4;
      Vec4 lo, hi, add_lo, add_hi;
      std::memcpy(&lo, s_prev, sizeof lo);
      std::memcpy(&hi, s_prev + tail, sizeof hi);
      std::memcpy(&add_lo, v, sizeof add_lo);
      std::memcpy(&add_hi, v + tail, sizeof add_hi);
      lo += add_lo;
      hi += add_hi;
      std::memcpy(s, &lo, sizeof lo);
      std::memcpy(s + tail, &hi, sizeof hi);
    } else {
      // Row by row in scalars (the entries are listed by row): each value is used right where
      // it is computed, never reloaded as a vector from scalar stores (a store-forwarding
      // stall). For a move, w + B_j Δu_j first, each row's product over B_j's nonzeros summed
      // first.
      for (int k = 0; k < ns_; ++k) {
        double v = w[k];
        if (b_row_begin != nullptr && b_row_begin[k] != b_row_begin[k + 1]) {
          double t = 0.0;
          for (int e = b_row_begin[k]; e < b_row_begin[k + 1]; ++e) {
            t += b_entries_[e].value * du[b_entries_[e].col];
          }
          v += t;
        }
        for (int e = row_begin[k]; e < row_begin[k + 1]; ++e) {
          v += a_entries_[e].value * ds[a_entries_[e].col];
        }
        dsn[k] = v;
        s[k] = s_prev[k] + v;
      }
    }
    std::swap(ds, dsn);
    for (int k = 0; k < ny_; ++k) {
      double v;
      if (c_one_per_row_) {  // the same sum without the loop
        v = y_prev[k] + c_entries_[k].value * ds[c_entries_[k].col];
      } else {
        v = y_prev[k];
        for (int e = c_row_begin_[k]; e < c_row_begin_[k + 1]; ++e) {
          v += c_entries_[e].value * ds[c_entries_[e].col];
        }
      }
      y[k] = v;
      const double err = d.reference(k, j) - v;
      cost += qdiag_[j * ny_ + k] * err * err;
    }
    s_prev = s;
    y_prev = y;
    s += ns_;
    y += ny_;
  }
  for (int i = 0; i < nc_; ++i) {
    for (int c = 0; c < nu_; ++c) {
      const double du = result_.moves[i * nu_ + c];
      cost += options_.move_weight[c] * du * du;
    }
  }
  cost += options_.slack_linear_weight * result_.slack.sum() +
          options_.slack_quadratic_weight * result_.slack.squaredNorm();
  result_.cost = cost;
}

const IncrementalMpcResult& IncrementalMpc::solve() {
  result_.invalid_field = check_data();
  if (!result_.invalid_field.empty()) {
    result_.qp_status = qp::QpStatus::kInvalidInput;
    result_.moves.setZero();
    result_.first_move.setZero();
    result_.first_input =
        data_.previous_input.size() == nu_ ? data_.previous_input : VecX::Zero(nu_);
    result_.slack.setZero();
    result_.max_slack = 0.0;
    result_.qp_iterations = 0;
    result_.qp_time_us = 0.0;
    result_.condensing_time_us = 0.0;
    result_.soft_rows_time_us = 0.0;
    result_.soft_rows_in_qp = 0;
    result_.prediction_rows_computed = 0;
    result_.prediction_replayed = false;
    return result_;
  }
  const bool timed = options_.time_parts;
  constexpr double kUntimed = std::numeric_limits<double>::quiet_NaN();
  auto start = timed ? Clock::now() : Clock::time_point{};
  build_prediction();
  build_cost();
  result_.condensing_time_us = timed ? elapsed_us(start) : kUntimed;
  assemble_qp();
  if (timed) start = Clock::now();
  const int old_soft_rows_in_qp = soft_rows_in_qp_;
  assemble_soft_rows();
  renumber_soft_rows(old_soft_rows_in_qp);
  result_.soft_rows_in_qp = kept_count_;
  result_.soft_rows_time_us = timed ? elapsed_us(start) : kUntimed;
  const qp::QpResult& qp_result = solver_.solve(qp_);
  result_.qp_status = qp_result.status;
  result_.qp_iterations = qp_result.iterations;
  result_.qp_time_us = qp_result.solve_time_us;
  extract_solution(qp_result);
  return result_;
}

}  // namespace ridgeline::mpc
