#include "mpc/incremental_mpc.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
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

bool IncrementalMpcData::add_soft_row(int step, const Eigen::Ref<const VecX>& a, double bound,
                                      int group) {
  const int capacity = static_cast<int>(soft_step.size());
  if (soft_row_count >= capacity || step < 0 || step >= reference.cols() || group < 0 ||
      a.size() != soft_normal.rows()) {
    return false;
  }
  soft_step[soft_row_count] = step;
  soft_group[soft_row_count] = group;
  soft_normal.col(soft_row_count) = a;
  soft_bound[soft_row_count] = bound;
  ++soft_row_count;
  return true;
}

IncrementalMpc::IncrementalMpc(const IncrementalMpcDims& dims, const IncrementalMpcOptions& options)
    : dims_(dims), options_(options), solver_(options.qp_settings) {
  require(dims.state_dim >= 1, "dims.state_dim", "must be >= 1");
  require(dims.input_dim >= 1, "dims.input_dim", "must be >= 1");
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
  nxi_ = ns_ + ny_;
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
  data_.soft_normal = MatX::Zero(ny_, cap);
  data_.soft_bound = VecX::Zero(cap);

  F_ = MatX::Zero(np_ * ny_, nxi_);
  Phi_ = MatX::Zero(np_ * ny_, nc_ * nu_);
  Yw_ = VecX::Zero(np_ * ny_);
  Yfree_ = VecX::Zero(np_ * ny_);
  SPhi_ = MatX::Zero(np_ * ny_, nc_ * nu_);
  err_ = VecX::Zero(np_ * ny_);
  qdiag_ = VecX::Zero(np_ * ny_);
  for (int j = 0; j < np_; ++j) {
    const bool terminal = j == np_ - 1 && options.terminal_output_weight.size() == ny_;
    qdiag_.segment(j * ny_, ny_) =
        terminal ? options.terminal_output_weight : options.output_weight;
  }
  qsqrt_ = qdiag_.cwiseSqrt();  // weights were validated ≥ 0
  y_ = VecX::Zero(ny_);
  tmp_ = VecX::Zero(ns_);
  P_ = RowMatX::Zero(ns_, nxi_ + 1 + nc_ * nu_);
  T_ = RowMatX::Zero(ns_, nxi_ + 1 + nc_ * nu_);
  Y_ = RowMatX::Zero(ny_, nxi_ + 1 + nc_ * nu_);
  ds_ = VecX::Zero(ns_);
  dsn_ = VecX::Zero(ns_);
  w_ = VecX::Zero(ns_);

  // QP layout: rows [input limits (Nc·n_u) | hard output limits (Np·n_y, optional) | soft].
  input_rows_begin_ = 0;
  output_rows_begin_ = nc_ * nu_;
  soft_rows_begin_ = output_rows_begin_ + (options.hard_output_limits ? np_ * ny_ : 0);
  soft_rows_in_qp_ = 0;
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
  // u_{k+i} = u_{k−1} + Σ_{l≤i} Δu_{k+l}: a block lower-triangular matrix of identities.
  for (int i = 0; i < nc_; ++i) {
    for (int l = 0; l <= i; ++l) {
      qp_.G.block(input_rows_begin_ + i * nu_, l * nu_, nu_, nu_).setIdentity();
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
      !has_shape(d.soft_normal, ny_, cap) || d.soft_bound.size() != cap || d.soft_row_count < 0 ||
      d.soft_row_count > cap) {
    return "soft rows (storage)";
  }
  for (int r = 0; r < d.soft_row_count; ++r) {
    if (d.soft_step[r] < 0 || d.soft_step[r] >= np_) return "soft_step";
    if (d.soft_group[r] < 0 || d.soft_group[r] >= ng_) return "soft_group";
  }
  return {};
}

void IncrementalMpc::build_prediction() {
  const IncrementalMpcData& d = data_;
  // One propagation of the augmented system (eq. 7) yields F, Y_w and Φ together. Its columns
  // are [F: n_ξ | Y_w: 1 | Φ: Nc·n_u]; P holds their Δs part, Y their y part:
  //   P ← A_j P (+ w_j in the Y_w column, + B_j in the column block of move j),  Y ← Y + C P.
  // F starts from ξ = I, Y_w and Φ from zero; a move's block starts at its own step.
  // P and Y are row-major and the products skip the exact zeros of A_j and C: a row update is
  // then one contiguous AXPY over all columns, and plant matrices such as I + Δt·A_c are mostly
  // zeros (13 of 49 entries for the UAV), which a dense small-matrix product would not exploit.
  const int wcol = nxi_;
  const int ucol0 = nxi_ + 1;
  RowMatX* P = &P_;
  RowMatX* T = &T_;
  P->setZero();
  Y_.setZero();
  P->leftCols(ns_).setIdentity();
  Y_.block(0, ns_, ny_, ny_).setIdentity();
  for (int j = 0; j < np_; ++j) {
    const int active = ucol0 + std::min(j, nc_) * nu_;  // F, Y_w and the started moves
    T->leftCols(active).setZero();
    const MatX& A = d.A[j];
    for (int l = 0; l < ns_; ++l) {
      for (int k = 0; k < ns_; ++k) {
        const double a = A(k, l);
        if (a != 0.0) T->row(k).head(active) += a * P->row(l).head(active);
      }
    }
    w_ = d.state_offset.col(j);
    if (nd_ > 0) w_.noalias() += d.E[j].lazyProduct(d.disturbance_delta.col(j));
    T->col(wcol) += w_;
    int used = active;
    if (j < nc_) {
      T->middleCols(ucol0 + j * nu_, nu_) = d.B[j];
      used += nu_;
    }
    for (int l = 0; l < ns_; ++l) {
      for (int k = 0; k < ny_; ++k) {
        const double c = d.C(k, l);
        if (c != 0.0) Y_.row(k).head(used) += c * T->row(l).head(used);
      }
    }
    std::swap(P, T);
    F_.middleRows(j * ny_, ny_) = Y_.leftCols(nxi_);
    Yw_.segment(j * ny_, ny_) = Y_.col(wcol);
    Phi_.block(j * ny_, 0, ny_, used - ucol0) = Y_.middleCols(ucol0, used - ucol0);
  }

  // Free response Y_free = F ξ_k + Y_w, ξ_k = [Δs_k; y_k].
  Yfree_.noalias() = F_.leftCols(ns_) * d.delta_state;
  Yfree_.noalias() += F_.rightCols(ny_) * d.output;
  Yfree_ += Yw_;
}

void IncrementalMpc::resize_soft_rows(int needed) {
  // The QP carries the soft rows in blocks of kSoftRowBlock, padded with rows whose sides are
  // both infinite: the size (and so the solver's workspace and warm start) changes only when
  // the count crosses a block, and it shrinks only when a whole block more than needed is
  // unused, so a count that wavers around a boundary does not resize every step.
  const int cap = dims_.soft_row_capacity;
  const int blocks = (needed + kSoftRowBlock - 1) / kSoftRowBlock;
  const int wanted = std::min(cap, blocks * kSoftRowBlock);
  if (wanted <= soft_rows_in_qp_ && soft_rows_in_qp_ - wanted <= kSoftRowBlock) return;
  soft_rows_in_qp_ = wanted;
  const int m = soft_rows_begin_ + wanted;
  qp_.G.conservativeResize(m, nz_);  // keeps the constant input-limit rows at the top
  qp_.lg.conservativeResize(m);
  qp_.ug.conservativeResize(m);
}

void IncrementalMpc::assemble_qp() {
  const IncrementalMpcData& d = data_;
  const int nU = nc_ * nu_;

  // Cost (eq. 10): H_uu = 2(ΦᵀQ̄Φ + R̄), f_u = −2ΦᵀQ̄(R − Y_free).
  // With S = Q̄^{1/2} (Q̄ ≥ 0), ΦᵀQ̄Φ = (SΦ)ᵀ(SΦ): a symmetric rank update costs half the
  // flops of the general product, and this product is the largest dense one in the step.
  SPhi_.noalias() = qsqrt_.asDiagonal() * Phi_;
  auto Huu = qp_.H.topLeftCorner(nU, nU);
  Huu.setZero();
  Huu.selfadjointView<Eigen::Lower>().rankUpdate(SPhi_.transpose(), 2.0);
  for (int c = 1; c < nU; ++c) {
    for (int r = 0; r < c; ++r) Huu(r, c) = Huu(c, r);
  }
  for (int i = 0; i < nc_; ++i) {
    for (int c = 0; c < nu_; ++c) Huu(i * nu_ + c, i * nu_ + c) += 2.0 * options_.move_weight[c];
  }
  for (int j = 0; j < np_; ++j) {
    err_.segment(j * ny_, ny_) = d.reference.col(j) - Yfree_.segment(j * ny_, ny_);
  }
  err_.array() *= qsqrt_.array();
  qp_.f.head(nU).noalias() = -2.0 * SPhi_.transpose() * err_;

  // Move bounds Δu_min ≤ Δu ≤ Δu_max (box); slack bounds σ ≥ 0 stay as built.
  for (int i = 0; i < nc_; ++i) {
    qp_.lb.segment(i * nu_, nu_) = d.move_min.col(i);
    qp_.ub.segment(i * nu_, nu_) = d.move_max.col(i);
  }
  // Input limits: u_min − u_{k−1} ≤ Σ Δu ≤ u_max − u_{k−1}.
  for (int i = 0; i < nc_; ++i) {
    qp_.lg.segment(input_rows_begin_ + i * nu_, nu_) = d.input_min.col(i) - d.previous_input;
    qp_.ug.segment(input_rows_begin_ + i * nu_, nu_) = d.input_max.col(i) - d.previous_input;
  }
  if (options_.hard_output_limits) {
    qp_.G.block(output_rows_begin_, 0, np_ * ny_, nU) = Phi_;
    for (int j = 0; j < np_; ++j) {
      const auto yf = Yfree_.segment(j * ny_, ny_);
      qp_.lg.segment(output_rows_begin_ + j * ny_, ny_) = d.output_min.col(j) - yf;
      qp_.ug.segment(output_rows_begin_ + j * ny_, ny_) = d.output_max.col(j) - yf;
    }
  }
  // Soft rows: aᵀ(Y_free,j + Φ_j ΔU) + σ_g ≥ b  ⇔  aᵀΦ_j ΔU + σ_g ≥ b − aᵀY_free,j.
  resize_soft_rows(d.soft_row_count);
  for (int r = 0; r < soft_rows_in_qp_; ++r) {
    auto row = qp_.G.row(soft_rows_begin_ + r);
    if (r < d.soft_row_count) {
      const int j = d.soft_step[r];
      const auto a = d.soft_normal.col(r);
      row.head(nU).noalias() = a.transpose().lazyProduct(Phi_.middleRows(j * ny_, ny_));
      row.tail(ng_).setZero();
      row[nU + d.soft_group[r]] = 1.0;
      qp_.lg[soft_rows_begin_ + r] = d.soft_bound[r] - a.dot(Yfree_.segment(j * ny_, ny_));
    } else {
      row.setZero();
      qp_.lg[soft_rows_begin_ + r] = -qp::kInfinity;
    }
    qp_.ug[soft_rows_begin_ + r] = qp::kInfinity;
  }
}

void IncrementalMpc::extract_solution(const qp::QpResult& qp_result) {
  const IncrementalMpcData& d = data_;
  const int nU = nc_ * nu_;
  // Only a solved QP's moves are used; otherwise the result describes the zero-move plan
  // (inputs held), which is what a caller falls back to.
  const bool usable = qp_result.status == qp::QpStatus::kSolved && qp_result.z.size() == nz_ &&
                      qp_result.z.allFinite();
  if (usable) {
    result_.moves = qp_result.z.head(nU);
    result_.slack = qp_result.z.tail(ng_).cwiseMax(0.0);
  } else {
    result_.moves.setZero();
    result_.slack.setZero();
  }
  result_.first_move = result_.moves.head(nu_);
  result_.first_input = d.previous_input + result_.first_move;
  result_.max_slack = ng_ > 0 ? result_.slack.maxCoeff() : 0.0;

  // Predicted outputs and states under ΔU: step the augmented system (eq. 7) directly.
  ds_ = d.delta_state;
  VecX& s = dsn_;  // running absolute state
  s = d.state;
  VecX& y = y_;
  y = d.output;
  double cost = 0.0;
  for (int j = 0; j < np_; ++j) {
    w_ = d.state_offset.col(j);
    if (nd_ > 0) w_.noalias() += d.E[j].lazyProduct(d.disturbance_delta.col(j));
    if (j < nc_) w_.noalias() += d.B[j].lazyProduct(result_.moves.segment(j * nu_, nu_));
    tmp_.noalias() = d.A[j].lazyProduct(ds_);
    ds_ = tmp_ + w_;
    s += ds_;
    y.noalias() += d.C.lazyProduct(ds_);
    result_.predicted_states.col(j) = s;
    result_.predicted_outputs.col(j) = y;
    for (int c = 0; c < ny_; ++c) {
      const double e = d.reference(c, j) - y[c];
      cost += qdiag_[j * ny_ + c] * e * e;
    }
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
  const auto start = Clock::now();
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
    result_.build_time_us = 0.0;
    return result_;
  }
  build_prediction();
  assemble_qp();
  result_.build_time_us = elapsed_us(start);
  const qp::QpResult& qp_result = solver_.solve(qp_);
  result_.qp_status = qp_result.status;
  result_.qp_iterations = qp_result.iterations;
  result_.qp_time_us = qp_result.solve_time_us;
  extract_solution(qp_result);
  return result_;
}

}  // namespace ridgeline::mpc
