// Tests of the plant-agnostic incremental MPC (src/mpc/incremental_mpc.*) on plants other
// than the UAV: random time-varying systems for the prediction matrices (eq. 8–9), and a
// linear longitudinal aircraft model for closed-loop tracking, limits and soft constraints.
#include "mpc/incremental_mpc.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <unsupported/Eigen/MatrixFunctions>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::mpc {
namespace {

MatX random_matrix(std::mt19937& rng, int rows, int cols, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MatX m(rows, cols);
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) m(i, j) = scale * u(rng);
  }
  return m;
}

// Φ with its columns in the QP's order (move, then input); IncrementalMpc::Phi() orders them
// by input, then move.
MatX phi_by_move(const IncrementalMpc& mpc) {
  const int nu = mpc.dims().input_dim, nc = mpc.options().control_horizon;
  MatX out(mpc.Phi().rows(), nu * nc);
  for (int i = 0; i < nc; ++i) {
    for (int c = 0; c < nu; ++c) out.col(i * nu + c) = mpc.Phi().col(c * nc + i);
  }
  return out;
}

IncrementalMpcOptions basic_options(int ny, int nu, int np, int nc) {
  IncrementalMpcOptions o;
  o.prediction_horizon = np;
  o.control_horizon = nc;
  o.output_weight = VecX::Ones(ny);
  o.move_weight = VecX::Ones(nu);
  return o;
}

// Y = Y_free + ΦΔU must equal stepping the augmented system of eq. 7 with explicitly formed
// Ã_j = [A_j 0; C A_j I], B̃_j = [B_j; C B_j] — an independent implementation of the same
// recursion. The products involve ≤ 40 factors of norm ≈ 1.1 on O(1) data, so rounding stays
// near 1e-13 relative; 1e-9 absolute is the brief's bound with a wide margin.
TEST(IncrementalMpcPrediction, MatricesMatchStepByStepAugmentedSimulationTimeVarying) {
  std::mt19937 rng(7);
  const int ns = 5, nu = 2, ny = 3, nd = 2, np = 25, nc = 6;
  IncrementalMpcDims dims{ns, nu, ny, nd, 0, 0};
  IncrementalMpc mpc(dims, basic_options(ny, nu, np, nc));
  IncrementalMpcData& d = mpc.data();
  d.C = random_matrix(rng, ny, ns, 1.0);
  for (int j = 0; j < np; ++j) {
    d.A[j] = MatX::Identity(ns, ns) + random_matrix(rng, ns, ns, 0.08);
    d.B[j] = random_matrix(rng, ns, nu, 0.5);
    d.E[j] = random_matrix(rng, ns, nd, 0.3);
  }
  d.delta_state = random_matrix(rng, ns, 1, 1.0);
  d.output = random_matrix(rng, ny, 1, 5.0);
  d.disturbance_delta = random_matrix(rng, nd, np, 0.2);
  d.state_offset = random_matrix(rng, ns, np, 0.05);
  mpc.build_prediction();
  const VecX dU = random_matrix(rng, nc * nu, 1, 1.0);

  VecX xi(ns + ny);
  xi << d.delta_state, d.output;
  VecX Y_sim(np * ny);
  for (int j = 0; j < np; ++j) {
    MatX At = MatX::Zero(ns + ny, ns + ny);
    At.topLeftCorner(ns, ns) = d.A[j];
    At.bottomLeftCorner(ny, ns) = d.C * d.A[j];
    At.bottomRightCorner(ny, ny).setIdentity();
    MatX Bt(ns + ny, nu);
    Bt << d.B[j], d.C * d.B[j];
    const VecX w = d.E[j] * d.disturbance_delta.col(j) + d.state_offset.col(j);
    VecX wt(ns + ny);
    wt << w, d.C * w;
    VecX du = VecX::Zero(nu);
    if (j < nc) du = dU.segment(j * nu, nu);
    xi = At * xi + Bt * du + wt;
    Y_sim.segment(j * ny, ny) = xi.tail(ny);
  }
  const MatX Phi = phi_by_move(mpc);
  const VecX Y_pred = mpc.free_response() + Phi * dU;
  EXPECT_LT((Y_pred - Y_sim).cwiseAbs().maxCoeff(), 1e-9);
  // Φ is block lower-triangular: a move cannot act on earlier outputs.
  EXPECT_EQ(Phi.topRightCorner(ny, (nc - 1) * nu).cwiseAbs().maxCoeff(), 0.0);
}

// For an LTI plant the incremental prediction must reproduce the ORIGINAL (absolute) plant
// s⁺ = A s + B u + E d, y = C s, simulated from s_{k−1}, s_k with u held after Nc and a
// time-varying measured disturbance: eq. 7 is exact then. Same rounding argument: 1e-9.
TEST(IncrementalMpcPrediction, LtiPredictionEqualsAbsolutePlantSimulation) {
  std::mt19937 rng(11);
  const int ns = 4, nu = 2, ny = 2, nd = 1, np = 30, nc = 5;
  IncrementalMpc mpc(IncrementalMpcDims{ns, nu, ny, nd, 0, 0}, basic_options(ny, nu, np, nc));
  IncrementalMpcData& d = mpc.data();
  const MatX A = MatX::Identity(ns, ns) + random_matrix(rng, ns, ns, 0.05);
  const MatX B = random_matrix(rng, ns, nu, 0.4);
  const MatX C = random_matrix(rng, ny, ns, 1.0);
  const MatX E = random_matrix(rng, ns, nd, 0.4);
  d.set_time_invariant(A, B, C, E);

  const VecX s_prev = random_matrix(rng, ns, 1, 2.0);
  const VecX u_prev = random_matrix(rng, nu, 1, 1.0);
  VecX dist(np + 1);  // d_{k−1}, d_k, …, d_{k+Np−1}
  for (int j = 0; j <= np; ++j) dist[j] = std::sin(0.3 * j);
  VecX s = A * s_prev + B * u_prev + E * dist.segment(0, 1);  // s_k
  // The step s_{k−1} → s_k used u_{k−1} and d_{k−1}.
  d.delta_state = s - s_prev;
  d.output = C * s;
  d.previous_input = u_prev;
  for (int j = 0; j < np; ++j) d.disturbance_delta(0, j) = dist[j + 1] - dist[j];
  mpc.build_prediction();

  const VecX dU = random_matrix(rng, nc * nu, 1, 1.0);
  VecX u = u_prev;
  VecX Y_sim(np * ny);
  for (int j = 0; j < np; ++j) {
    if (j < nc) u += dU.segment(j * nu, nu);
    s = A * s + B * u + E * dist.segment(j + 1, 1);
    Y_sim.segment(j * ny, ny) = C * s;
  }
  const VecX Y_pred = mpc.free_response() + phi_by_move(mpc) * dU;
  EXPECT_LT((Y_pred - Y_sim).cwiseAbs().maxCoeff(), 1e-9);
}

// The textbook dense condensing, the reference for the structured one of IncrementalMpc: the
// augmented system Ã_j = [A_j 0; C A_j I], B̃_j = [B_j; C B_j], w̃_j = [w_j; C w_j] formed
// explicitly, F, Φ and Y_w stacked by dense products, then H_uu = 2(ΦᵀQ̄Φ + R̄) and
// f_u = −2ΦᵀQ̄(R − Fξ − Y_w), and each soft row aᵀΦ_j ΔU + σ_g ≥ b − aᵀ(Fξ + Y_w)_j.
struct DenseCondensing {
  MatX H;   // Nc·n_u square
  VecX f;   // Nc·n_u
  MatX G;   // soft rows × Nc·n_u
  VecX lg;  // soft rows
};

DenseCondensing dense_condensing(const IncrementalMpcData& d, const IncrementalMpcOptions& o) {
  const int ns = static_cast<int>(d.C.cols()), ny = static_cast<int>(d.C.rows());
  const int nu = static_cast<int>(d.B[0].cols()), nxi = ns + ny;
  const int np = o.prediction_horizon, nc = o.control_horizon;
  std::vector<MatX> At(np), Bt(np);
  std::vector<VecX> wt(np);
  for (int j = 0; j < np; ++j) {
    At[j] = MatX::Zero(nxi, nxi);
    At[j].topLeftCorner(ns, ns) = d.A[j];
    At[j].bottomLeftCorner(ny, ns) = d.C * d.A[j];
    At[j].bottomRightCorner(ny, ny).setIdentity();
    Bt[j] = MatX(nxi, nu);
    Bt[j] << d.B[j], d.C * d.B[j];
    const VecX w = d.E[j] * d.disturbance_delta.col(j) + d.state_offset.col(j);
    wt[j] = VecX(nxi);
    wt[j] << w, d.C * w;
  }
  MatX Ct = MatX::Zero(ny, nxi);
  Ct.rightCols(ny).setIdentity();
  MatX F(np * ny, nxi), Phi = MatX::Zero(np * ny, nc * nu);
  VecX Yw(np * ny);
  MatX X = MatX::Identity(nxi, nxi);
  VecX v = VecX::Zero(nxi);
  for (int j = 0; j < np; ++j) {
    X = At[j] * X;
    v = At[j] * v + wt[j];
    F.middleRows(j * ny, ny) = Ct * X;
    Yw.segment(j * ny, ny) = Ct * v;
  }
  for (int i = 0; i < nc; ++i) {
    MatX M = Bt[i];
    for (int j = i; j < np; ++j) {
      if (j > i) M = At[j] * M;
      Phi.block(j * ny, i * nu, ny, nu) = Ct * M;
    }
  }
  VecX xi(nxi);
  xi << d.delta_state, d.output;
  const VecX Yfree = F * xi + Yw;
  VecX q(np * ny), R(np * ny);
  for (int j = 0; j < np; ++j) {
    q.segment(j * ny, ny) = j == np - 1 && o.terminal_output_weight.size() == ny
                                ? o.terminal_output_weight
                                : o.output_weight;
    R.segment(j * ny, ny) = d.reference.col(j);
  }
  DenseCondensing out;
  out.H = 2.0 * Phi.transpose() * q.asDiagonal() * Phi;
  for (int i = 0; i < nc; ++i) {
    out.H.diagonal().segment(i * nu, nu) += 2.0 * o.move_weight;
  }
  out.f = -2.0 * Phi.transpose() * q.asDiagonal() * (R - Yfree);
  out.G = MatX(d.soft_row_count, nc * nu);
  out.lg = VecX(d.soft_row_count);
  for (int r = 0; r < d.soft_row_count; ++r) {
    const int j = d.soft_step[r];
    out.G.row(r) = d.soft_normal.col(r).transpose() * Phi.middleRows(j * ny, ny);
    out.lg[r] = d.soft_bound[r] - d.soft_normal.col(r).dot(Yfree.segment(j * ny, ny));
  }
  return out;
}

// Fills a step's data with random values on the plant already in d.A/B/E/C and solves it.
void randomize_step_and_solve(std::mt19937& rng, IncrementalMpc& mpc, int soft_rows) {
  IncrementalMpcData& d = mpc.data();
  const int ns = mpc.dims().state_dim, ny = mpc.dims().output_dim;
  const int nd = mpc.dims().disturbance_dim, np = mpc.options().prediction_horizon;
  d.delta_state = random_matrix(rng, ns, 1, 1.0);
  d.output = random_matrix(rng, ny, 1, 50.0);
  d.state = random_matrix(rng, ns, 1, 50.0);
  d.disturbance_delta = random_matrix(rng, nd, np, 0.3);
  d.state_offset = random_matrix(rng, ns, np, 0.05);
  d.reference = random_matrix(rng, ny, np, 50.0);
  d.clear_soft_rows();
  std::uniform_int_distribution<int> step(0, np - 1);
  for (int r = 0; r < soft_rows; ++r) {
    const VecX a = random_matrix(rng, ny, 1, 1.0);
    ASSERT_TRUE(d.add_soft_row(step(rng), a, 10.0 * a(0, 0), r % mpc.dims().slack_groups));
  }
  mpc.solve();
}

// Structured and dense condensing must agree to round-off. Each entry is a sum of at most
// Np·n_y products of O(1)–O(1e2) terms summed in another order, so the difference is a few
// hundred ulps of the largest entry at most; 1e-11 relative to it leaves a wide margin and
// still catches any wrong term (those are O(1) relative).
void expect_condensing_equals_dense(const IncrementalMpc& mpc) {
  const DenseCondensing ref = dense_condensing(mpc.data(), mpc.options());
  const qp::QpProblem& qp = mpc.qp_problem();
  const int nu = mpc.dims().input_dim, nc = mpc.options().control_horizon, nU = nc * nu;
  // The QP orders ΔU by input, then move; the reference by move, then input.
  std::vector<int> qp_index(nU);
  for (int i = 0; i < nc; ++i) {
    for (int c = 0; c < nu; ++c) qp_index[i * nu + c] = c * nc + i;
  }
  const int soft = mpc.data().soft_row_count;
  const int first_soft = nU;  // after the input-limit rows (no hard output limits here)
  ASSERT_GE(qp.G.rows(), first_soft + soft);
  MatX H(nU, nU), G(soft, nU);
  VecX f(nU);
  for (int a = 0; a < nU; ++a) {
    f[a] = qp.f[qp_index[a]];
    for (int b = 0; b < nU; ++b) H(a, b) = qp.H(qp_index[a], qp_index[b]);
    for (int r = 0; r < soft; ++r) G(r, a) = qp.G(first_soft + r, qp_index[a]);
  }
  EXPECT_LE((H - ref.H).cwiseAbs().maxCoeff(), 1e-11 * ref.H.cwiseAbs().maxCoeff());
  EXPECT_EQ(H, H.transpose());
  EXPECT_LE((f - ref.f).cwiseAbs().maxCoeff(), 1e-11 * ref.f.cwiseAbs().maxCoeff());
  EXPECT_LE((G - ref.G).cwiseAbs().maxCoeff(), 1e-11 * ref.G.cwiseAbs().maxCoeff());
  const auto lg = qp.lg.segment(first_soft, soft);
  EXPECT_LE((lg - ref.lg).cwiseAbs().maxCoeff(), 1e-11 * ref.lg.cwiseAbs().maxCoeff());
}

// Plants of 3 to 9 states: the free response sums A_j·Δs over the listed nonzeros below 4 and
// above 8 states, over whole columns in between (IncrementalMpc's dense columns).
TEST(IncrementalMpcCondensing, EqualsDenseCondensingOnRandomDensePlants) {
  std::mt19937 rng(21);
  for (int trial = 0; trial < 7; ++trial) {
    const int ns = 3 + trial, nu = 1 + trial % 3, ny = 1 + trial % 3, np = 12 + 7 * trial;
    const int nc = 1 + 2 * trial;
    IncrementalMpcOptions o = basic_options(ny, nu, np, nc);
    o.output_weight = random_matrix(rng, ny, 1, 1.0).cwiseAbs();
    o.terminal_output_weight = 3.0 * o.output_weight;
    o.move_weight = random_matrix(rng, nu, 1, 1.0).cwiseAbs().array() + 0.1;
    o.drop_redundant_soft_rows = false;  // every soft row in the QP, to compare them all
    IncrementalMpc mpc(IncrementalMpcDims{ns, nu, ny, 2, 4 * np, 2}, o);
    IncrementalMpcData& d = mpc.data();
    d.C = random_matrix(rng, ny, ns, 1.0);
    for (int j = 0; j < np; ++j) {
      d.A[j] = MatX::Identity(ns, ns) + random_matrix(rng, ns, ns, 0.1);
      d.B[j] = random_matrix(rng, ns, nu, 0.5);
      d.E[j] = random_matrix(rng, ns, 2, 0.3);
    }
    randomize_step_and_solve(rng, mpc, 2 * np);
    SCOPED_TRACE(trial);
    expect_condensing_equals_dense(mpc);
  }
}

// The UAV's Euler Jacobians (eq. 4) along random nominal states: x, y are reached only by the
// speed and turn commands, z only by the climb command, which the structured sums exploit. A
// heading of exactly 0 makes sin ψ̄ an exact zero of A_j at some steps. A fourth output reads
// a state no input reaches (its rows of Φ are zero) and must add nothing. Φ's columns outside
// a row's reach are never written, so a dense plant solved before must leave no trace.
TEST(IncrementalMpcCondensing, EqualsDenseCondensingOnTheUavModelWithUnreachedOutput) {
  std::mt19937 rng(42);
  const vehicle::VehicleParams p;
  const int ns = vehicle::kStateDim + 1, nu = vehicle::kInputDim, ny = 4, np = 40, nc = 10;
  IncrementalMpcOptions o = basic_options(ny, nu, np, nc);
  o.output_weight = Eigen::Vector4d(1.0, 1.0, 2.0, 5.0);
  o.move_weight = Eigen::Vector3d(2.0, 200.0, 2.0);
  o.drop_redundant_soft_rows = false;  // every soft row in the QP, to compare them all
  IncrementalMpc mpc(IncrementalMpcDims{ns, nu, ny, 3, 4 * np, 3}, o);
  IncrementalMpcData& d = mpc.data();
  d.C = MatX::Zero(ny, ns);
  d.C.topLeftCorner(3, 3).setIdentity();
  d.C(3, ns - 1) = 1.0;  // an extra state integrating nothing the inputs move
  // First a dense plant, whose Φ is nonzero everywhere: the sparser reaches after it must not
  // keep its entries.
  for (int j = 0; j < np; ++j) {
    d.A[j] = MatX::Identity(ns, ns) + random_matrix(rng, ns, ns, 0.05);
    d.B[j] = random_matrix(rng, ns, nu, 0.5);
  }
  randomize_step_and_solve(rng, mpc, np);
  expect_condensing_equals_dense(mpc);
  std::uniform_real_distribution<double> heading(-kPi, kPi);
  for (int trial = 0; trial < 3; ++trial) {
    for (int j = 0; j < np; ++j) {
      vehicle::State s = vehicle::State::Zero();
      s[vehicle::kPsi] = (trial == 0 && j % 5 == 0) ? 0.0 : heading(rng);
      s[vehicle::kV] = 8.0 + 4.0 * (j % 3);
      const vehicle::Jacobians J = vehicle::discrete_jacobians(s, p, 0.1);
      d.A[j] = MatX::Identity(ns, ns);
      d.A[j].topLeftCorner(vehicle::kStateDim, vehicle::kStateDim) = J.A;
      d.A[j](ns - 1, ns - 1) = 0.9;
      d.B[j] = MatX::Zero(ns, nu);
      d.B[j].topRows(vehicle::kStateDim) = J.B;
      d.E[j] = MatX::Zero(ns, 3);
      d.E[j].topRows(vehicle::kStateDim) = J.E;
    }
    randomize_step_and_solve(rng, mpc, 3 * np);
    SCOPED_TRACE(trial);
    expect_condensing_equals_dense(mpc);
  }
}

// The UAV's tracker in small: outputs x, y, z, its move weights and rate-limited moves.
IncrementalMpcOptions uav_options(int np, int nc) {
  IncrementalMpcOptions o = basic_options(3, vehicle::kInputDim, np, nc);
  o.output_weight = Eigen::Vector3d(1.0, 1.0, 2.0);
  o.move_weight = Eigen::Vector3d(2.0, 200.0, 2.0);
  o.move_min = -Eigen::Vector3d(0.2, 0.03, 0.1);
  o.move_max = Eigen::Vector3d(0.2, 0.03, 0.1);
  return o;
}

// The UAV's Jacobians (Δt 0.1 s) along a nominal turning at heading_rate a step and speeding
// up by speed_rate a step, and C reading the position.
void set_uav_plant(IncrementalMpcData& d, double psi0, double heading_rate, double speed_rate) {
  const vehicle::VehicleParams p;
  for (std::size_t j = 0; j < d.A.size(); ++j) {
    vehicle::State s = vehicle::State::Zero();
    s[vehicle::kPsi] = psi0 + heading_rate * static_cast<double>(j);
    s[vehicle::kV] = 12.0 + speed_rate * static_cast<double>(j);
    const vehicle::Jacobians J = vehicle::discrete_jacobians(s, p, 0.1);
    d.A[j] = J.A;
    d.B[j] = J.B;
    d.E[j] = J.E;
  }
  d.C = MatX::Zero(3, vehicle::kStateDim);
  d.C.leftCols(3).setIdentity();
}

// A step's data about the UAV plant (drawn in this order): the increment, the output and state
// tens of metres out, and a reference within a few metres of the output at every step.
void set_random_step(IncrementalMpcData& d, std::mt19937& rng, int ns, int ny, int np) {
  d.delta_state = random_matrix(rng, ns, 1, 0.05);
  d.output = random_matrix(rng, ny, 1, 50.0);
  d.state = random_matrix(rng, ns, 1, 50.0);
  d.reference = random_matrix(rng, ny, np, 3.0);
  for (int j = 0; j < np; ++j) d.reference.col(j) += d.output;
}

// The climb's move box (input 2): ±climb at every move.
void set_climb_box(IncrementalMpcData& d, double climb) {
  d.move_min.row(2).setConstant(-climb);
  d.move_max.row(2).setConstant(climb);
}

// Bit for bit (memcmp: −0 differs from +0, a NaN equals the same NaN).
template <typename Matrix>
bool same_bits(const Matrix& a, const Matrix& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

// Bit for bit after both solved: Φ, the free response, H, f, the move box, and the QP's rows (the
// input limits and the soft rows kept) with their bounds.
void expect_same_build(const IncrementalMpc& kept, const IncrementalMpc& fresh) {
  EXPECT_TRUE(same_bits(kept.Phi(), fresh.Phi()));
  EXPECT_TRUE(same_bits(kept.free_response(), fresh.free_response()));
  const qp::QpProblem& a = kept.qp_problem();
  const qp::QpProblem& b = fresh.qp_problem();
  EXPECT_TRUE(same_bits(a.H, b.H));
  EXPECT_TRUE(same_bits(a.f, b.f));
  EXPECT_TRUE(same_bits(a.lb, b.lb));
  EXPECT_TRUE(same_bits(a.ub, b.ub));
  const int kept_rows = kept.last_result().soft_rows_in_qp;
  ASSERT_EQ(kept_rows, fresh.last_result().soft_rows_in_qp);
  const int rows = kept.options().control_horizon * kept.dims().input_dim + kept_rows;
  EXPECT_TRUE(same_bits(MatX(a.G.topRows(rows)), MatX(b.G.topRows(rows))));
  EXPECT_TRUE(same_bits(VecX(a.lg.head(rows)), VecX(b.lg.head(rows))));
  EXPECT_TRUE(same_bits(VecX(a.ug.head(rows)), VecX(b.ug.head(rows))));
}

// The condensing keeps the rows of Γ and Φ that did not change since the last step. A
// controller that has run for many steps must build exactly (bit for bit) the QP a new one
// builds from the same data, whatever changed in between: the heading-dependent entries of
// A_j (the tracker's every step), a constant row of one A_j (also between a caller's
// build_prediction() and the solve's), a B_j, C, a new nonzero in A_j and its removal, one
// input's move box, a NaN entry and its removal, or nothing at all.
TEST(IncrementalMpcCondensing, RowsKeptFromTheLastStepEqualAFreshBuild) {
  std::mt19937 rng(8);
  const int ns = vehicle::kStateDim, nu = vehicle::kInputDim, ny = 3, np = 24, nc = 6;
  const IncrementalMpcOptions o = uav_options(np, nc);
  const IncrementalMpcDims dims{ns, nu, ny, 3, 2 * np, 2};
  IncrementalMpc kept(dims, o);
  IncrementalMpcData& d = kept.data();
  std::uniform_real_distribution<double> heading(-kPi, kPi), unit(0.0, 1.0);
  std::uniform_int_distribution<int> any_step(0, np - 1), move_step(0, nc - 1);
  const auto uav_plant = [&](double psi0) { set_uav_plant(d, psi0, 0.03, 0.1); };
  uav_plant(0.3);
  constexpr int kChanges = 11;
  const int all_rows = (ns + ny) * np;
  int fewer = 0, none = 0;
  for (int step = 0; step < 4 * kChanges; ++step) {
    const int change = step % kChanges;
    switch (change) {
      case 0:  // the tracker's step: a new nominal heading and speed
        uav_plant(heading(rng));
        break;
      case 1:  // a constant row's value at one step, after the build below (before the solve)
        break;
      case 2:  // an input's effect at one move
        d.B[move_step(rng)](vehicle::kOmega, 1) *= 1.0 + 0.1 * unit(rng);
        break;
      case 3:  // C
        d.C(2, 2) = 1.0 + 0.1 * unit(rng);
        break;
      case 4:  // a new nonzero: the speed now climbs at one step
        d.A[any_step(rng)](vehicle::kZ, vehicle::kV) = 0.01;
        break;
      case 5:  // ... and no longer
        for (int j = 0; j < np; ++j) d.A[j](vehicle::kZ, vehicle::kV) = 0.0;
        break;
      case 6:  // one input's move box (the climb's, which the altitude rows below test)
        set_climb_box(d, 0.02 + 0.3 * unit(rng));
        break;
      case 7:  // a heading-dependent entry at one step only: x changes there, y does not
        d.A[any_step(rng)](vehicle::kX, vehicle::kPsi) *= 1.01;
        break;
      case 8:  // NaN in a constant row: the QP must be rejected ...
        d.A[any_step(rng)](vehicle::kW, vehicle::kW) = std::nan("");
        break;
      case 9:  // ... and the next step, with the row restored, is built right
        for (int j = 0; j < np; ++j) {
          if (std::isnan(d.A[j](vehicle::kW, vehicle::kW))) d.A[j](vehicle::kW, vehicle::kW) = 0.9;
        }
        break;
      default:  // nothing changed
        break;
    }
    set_random_step(d, rng, ns, ny, np);
    d.clear_soft_rows();
    for (int j = 0; j < np; j += 3) {
      Vec3 a = random_matrix(rng, 3, 1, 1.0);
      a.normalize();
      d.add_soft_row(j, a, a.dot(d.output) + 40.0 * (unit(rng) - 0.9), 0, 0);
    }
    // Altitude floors from 3 m below to 1 m above the free response, whether the climb's
    // moves can violate them depending on its box.
    // (A second build before the solve's own finds nothing changed: the cost and the ranges
    // must still follow the rows the first one computed.)
    kept.build_prediction();
    const int computed = kept.last_result().prediction_rows_computed;
    if (change == 1) d.A[any_step(rng)](vehicle::kV, vehicle::kV) *= 1.0 + 0.1 * unit(rng);
    for (int j = 1; j < np; j += 2) {
      const double free_z = kept.free_response()[j * ny + 2];
      d.add_soft_row(j, Vec3::UnitZ(), free_z - 3.0 + 4.0 * unit(rng), 1, 0);
    }
    const IncrementalMpcResult& r = kept.solve();
    IncrementalMpc fresh(dims, o);
    fresh.data() = d;
    const IncrementalMpcResult& f = fresh.solve();
    SCOPED_TRACE(step);
    ASSERT_EQ(r.qp_status == qp::QpStatus::kInvalidInput,
              f.qp_status == qp::QpStatus::kInvalidInput);
    EXPECT_EQ(f.prediction_rows_computed, all_rows);
    if (change == 8) {
      EXPECT_EQ(r.qp_status, qp::QpStatus::kInvalidInput);  // the NaN reached the QP
    }
    // The solve's build after the one above: only the change made in between, and after a
    // new heading the rows that changed at every step (x and y), which keep no history.
    if (change == 1 || (change == 0 && step > 0)) {
      EXPECT_GT(r.prediction_rows_computed, 0);
    } else {
      EXPECT_EQ(r.prediction_rows_computed, 0);
    }
    if (change == 10) {
      EXPECT_EQ(computed, 0);
    }
    fewer += computed < all_rows ? 1 : 0;
    none += computed == 0 ? 1 : 0;
    expect_same_build(kept, fresh);
  }
  // Rows were kept at the steps of changes 0, 2, 3 (Γ), 6, 7, 8, 9 and 10 (not only where
  // nothing changed), and none computed at those of 1 (before its change), 6 and 10.
  EXPECT_GE(fewer, 4 * 8 - 1);
  EXPECT_GE(none, 4 * 3);
}

// The tracker's steady state: a new nominal at every step changes the x and y rows of every
// A_j and nothing else, so that each pass after the first few replays the last one's row
// updates (see forward_pass). Runs of such steps, broken by changes that make the pass decide
// its rows again (a B_j, C, a constant row's value, a new nonzero, the same heading twice, a
// changed box); replays exactly where expected; at each step the QP's data equal bit for bit those
// of a controller that decides every row, with soft rows near the edge of what the moves reach
// (whose ranges the replayed updates must mark) and altitude floors (their group's block of H).
TEST(IncrementalMpcCondensing, ReplayedRowUpdatesEqualAFreshBuild) {
  std::mt19937 rng(21);
  const int ns = vehicle::kStateDim, nu = vehicle::kInputDim, ny = 3, np = 20, nc = 5;
  const IncrementalMpcOptions o = uav_options(np, nc);
  const IncrementalMpcDims dims{ns, nu, ny, 3, 3 * np, 2};
  IncrementalMpc kept(dims, o);
  IncrementalMpcData& d = kept.data();
  std::uniform_real_distribution<double> heading(-kPi, kPi), unit(0.0, 1.0);
  double psi = 0.4;
  for (int step = 0; step < 96; ++step) {
    SCOPED_TRACE(step);
    const int change = step % 16;
    // At 7 the same heading as the step before (the turn and speed rates drawn anew): A_0's
    // rows do not change, so no row changes at every step and the rows to compute differ.
    if (change != 7) psi = heading(rng);
    set_uav_plant(d, psi, 0.02 * unit(rng), 0.1 * unit(rng));
    switch (change) {
      case 2:  // a new nonzero (x reads the turn rate) at one step, the reaches the same ...
        d.A[3](vehicle::kX, vehicle::kOmega) = 0.001;
        break;
      case 3:  // ... at the next one instead: the same masks, the entries in other places
        d.A[4](vehicle::kX, vehicle::kOmega) = 0.001;
        break;
      case 8:  // an input's effect at one move
        d.B[static_cast<std::size_t>(step % nc)](vehicle::kOmega, 1) *= 1.05;
        break;
      case 9:  // a constant row's value at one step (the listing stays)
        d.A[static_cast<std::size_t>(step % np)](vehicle::kV, vehicle::kV) *= 1.0 + 0.1 * unit(rng);
        break;
      case 10:  // C
        d.C(1, 1) = 1.0 + 0.1 * unit(rng);
        break;
      case 11:  // the climb's move box
        set_climb_box(d, 0.02 + 0.3 * unit(rng));
        break;
      default:  // 0, 1, 4, 5, 6, 12–15: a new nominal only
        break;
    }
    set_random_step(d, rng, ns, ny, np);
    // Soft rows on x, y and z and altitude floors, their bounds from 4 m inside to 1 m outside
    // the free response (from a controller of its own, so that `kept` builds once a step): many
    // near the edge of what the moves can reach, so that a row's range that missed a change
    // would keep or drop the wrong rows.
    IncrementalMpc probe(dims, o);
    probe.data() = d;
    probe.build_prediction();
    const VecX& free = probe.free_response();
    d.clear_soft_rows();
    for (int j = 0; j + 1 < np; j += 2) {
      Vec3 a = random_matrix(rng, 3, 1, 1.0);
      a.normalize();
      d.add_soft_row(j, a, a.dot(free.segment(j * ny, ny)) - 4.0 + 5.0 * unit(rng), 0, 0);
      d.add_soft_row(j + 1, Vec3::UnitZ(), free[(j + 1) * ny + 2] - 4.0 + 5.0 * unit(rng), 1, 0);
    }
    const IncrementalMpcResult& r = kept.solve();
    IncrementalMpc fresh(dims, o);
    fresh.data() = d;
    const IncrementalMpcResult& f = fresh.solve();
    ASSERT_TRUE(r.solved());
    ASSERT_TRUE(f.solved());
    // After a new nominal only the x and y rows: two rows of Γ and two of Φ a step.
    if (step > 2 && (change <= 1 || change == 5 || change == 6 || change >= 12)) {
      EXPECT_EQ(r.prediction_rows_computed, 4 * np);
    }
    // Replayed exactly where what decides the rows is the last pass's: after a step with a new
    // nominal only, that pass itself recorded (not at 12, after C's change and its undoing).
    const bool replays = change <= 1 || change == 6 || change >= 13;
    if (step >= 16) {
      EXPECT_EQ(r.prediction_replayed, replays);
    }
    EXPECT_FALSE(f.prediction_replayed);
    expect_same_build(kept, fresh);
  }
}

// A plant whose state k reads states k and k + 1 (A_j with zeros), moved by its last two states
// (n_u = 2), and whose outputs are states 0 and second_output (n_y = 2).
void set_chain_plant(IncrementalMpcData& d, std::mt19937& rng, int second_output) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int ns = static_cast<int>(d.delta_state.size());
  d.C = MatX::Zero(2, ns);
  d.C(0, 0) = 1.0;
  d.C(1, second_output) = 1.0;
  for (std::size_t j = 0; j < d.A.size(); ++j) {
    d.A[j] = MatX::Zero(ns, ns);
    for (int k = 0; k < ns; ++k) {
      d.A[j](k, k) = 0.9 + 0.1 * unit(rng);
      if (k + 1 < ns) d.A[j](k, k + 1) = 0.1 + 0.1 * unit(rng);
    }
    d.B[j] = MatX::Zero(ns, 2);
    d.B[j](ns - 1, 0) = 0.1;
    d.B[j](ns - 2, 1) = 0.2;
  }
}

// New measurements and references into `kept`, solved after its earlier steps and by a fresh
// controller on the same data: Φ, the free response, H and f must be equal bit for bit, and
// the fresh one computes every row. Returns the rows `kept` computed.
int expect_kept_equals_fresh(IncrementalMpc& kept, std::mt19937& rng) {
  IncrementalMpcData& d = kept.data();
  const int ns = kept.dims().state_dim, ny = kept.dims().output_dim;
  const int np = static_cast<int>(d.reference.cols());
  d.delta_state = random_matrix(rng, ns, 1, 0.05);
  d.output = random_matrix(rng, ny, 1, 5.0);
  d.state = random_matrix(rng, ns, 1, 5.0);
  d.reference = random_matrix(rng, ny, np, 3.0);
  const IncrementalMpcResult& r = kept.solve();
  IncrementalMpc fresh(kept.dims(), kept.options());
  fresh.data() = d;
  const IncrementalMpcResult& f = fresh.solve();
  if (!r.solved() || !f.solved()) {
    ADD_FAILURE() << "not solved: kept " << r.solved() << ", fresh " << f.solved();
    return -1;
  }
  EXPECT_EQ(f.prediction_rows_computed, (ns + ny) * np);
  EXPECT_TRUE(same_bits(kept.Phi(), fresh.Phi()));
  EXPECT_TRUE(same_bits(kept.free_response(), fresh.free_response()));
  EXPECT_TRUE(same_bits(kept.qp_problem().H, fresh.qp_problem().H));
  EXPECT_TRUE(same_bits(kept.qp_problem().f, fresh.qp_problem().f));
  return r.prediction_rows_computed;
}

// The same on plants of 3, 6 and 9 states whose A_j have zeros (state k reads states k and
// k + 1), whose first two rows change at every step (as the UAV's x and y) and one other row of
// one A_j at some steps, and whose nonzeros move at other steps (as many, in other places): the
// listing of A_j's nonzeros follows them, and the rows of Γ computed anew follow each state's
// dependents in A_j, with the free response over the listed nonzeros (3 and 9 states) and over
// whole columns (6).
TEST(IncrementalMpcCondensing, KeptRowsFollowTheDependentsOnSparsePlants) {
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const int ns : {3, 6, 9}) {
    SCOPED_TRACE(ns);
    const int nu = 2, ny = 2, np = 15, nc = 4;
    const IncrementalMpcOptions o = basic_options(ny, nu, np, nc);
    const IncrementalMpcDims dims{ns, nu, ny, 0, 0, 0};
    IncrementalMpc kept(dims, o);
    IncrementalMpcData& d = kept.data();
    set_chain_plant(d, rng, 1);
    const int all_rows = (ns + ny) * np;
    int fewer = 0;
    for (int step = 0; step < 12; ++step) {
      for (int j = 0; j < np; ++j) {  // the rows that change at every step
        for (int k = 0; k < 2; ++k) d.A[j](k, k + 1) = 0.1 + 0.1 * unit(rng);
      }
      if (step % 3 == 1) {  // one other row of one A_j
        const int row = 2 + static_cast<int>(unit(rng) * (ns - 2));
        d.A[static_cast<int>(unit(rng) * np)](row, row) *= 1.0 + 0.01 * unit(rng);
      }
      if (step % 4 == 2 && ns > 3) {
        // A nonzero of one A_j moves (state k + 1 now reads k instead of k reading k + 1): as
        // many nonzeros as before, in other places.
        const int j = static_cast<int>(unit(rng) * np);
        const int k = ns - 2;
        std::swap(d.A[j](k, k + 1), d.A[j](k + 1, k));
      }
      SCOPED_TRACE(step);
      const int computed = expect_kept_equals_fresh(kept, rng);
      fewer += computed < all_rows ? 1 : 0;
    }
    // Rows were kept after the first step, except where the extra change came at step 0 of a
    // plant whose every row then reads it (3 states).
    EXPECT_GE(fewer, 7);
  }
}

// A plant of more than 64 states, whose rows a 64-bit mask cannot tell apart (row 64 shares bit
// 0 with row 0, row 65 bit 1 with row 1): every row is computed at every step, and the listed
// values of A_j must follow every change, below row 64 and in rows 64 and 65 (the same Φ, free
// response and cost as a fresh build).
TEST(IncrementalMpcCondensing, PlantsOfMoreThan64StatesReadEveryChangedValue) {
  std::mt19937 rng(65);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int ns = 66, nu = 2, ny = 2, np = 5, nc = 2;
  IncrementalMpc kept(IncrementalMpcDims{ns, nu, ny, 0, 0, 0}, basic_options(ny, nu, np, nc));
  IncrementalMpcData& d = kept.data();
  set_chain_plant(d, rng, ns - 1);
  for (int step = 0; step < 6; ++step) {
    for (int j = 0; j < np; ++j) {  // rows 1, 65 (bit 1 as row 1) and 64 (bit 0)
      d.A[j](1, 2) = 0.1 + 0.1 * unit(rng);
      if (step % 2 == 1) d.A[j](65, 65) = 0.9 + 0.1 * unit(rng);
      if (step % 3 == 2) d.A[j](64, 65) = 0.1 + 0.1 * unit(rng);
    }
    SCOPED_TRACE(step);
    EXPECT_EQ(expect_kept_equals_fresh(kept, rng), (ns + ny) * np);
  }
}

// A plant of 4 to 8 states takes its free response (A_j) and its solution's prediction (A_j and
// B_j) over whole columns; one of more states over the listed nonzeros. The same 6-state plant,
// alone and with three uncoupled states appended (9 states), must give the same moves and the
// same predicted states and outputs bit for bit, step after step as A_j changes: the two sum the
// same products in the same order.
TEST(IncrementalMpcPrediction, WholeColumnsEqualTheListedNonzerosBitForBit) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int ns = 6, extra = 3, nu = 2, ny = 2, nd = 1, np = 12, nc = 4;
  const IncrementalMpcOptions o = basic_options(ny, nu, np, nc);
  IncrementalMpc small(IncrementalMpcDims{ns, nu, ny, nd, 0, 0}, o);
  IncrementalMpc large(IncrementalMpcDims{ns + extra, nu, ny, nd, 0, 0}, o);
  IncrementalMpcData& a = small.data();
  IncrementalMpcData& b = large.data();
  a.C = MatX::Zero(ny, ns);
  a.C(0, 0) = 1.0;
  a.C(1, 2) = 1.0;
  b.C = MatX::Zero(ny, ns + extra);
  b.C.leftCols(ns) = a.C;
  for (int j = 0; j < np; ++j) {
    a.B[j] = MatX::Zero(ns, nu);
    a.B[j](ns - 1, 0) = 0.1;
    a.B[j](ns - 2, 1) = 0.2;
    a.B[j](ns - 3, 1) = -0.05;
    a.E[j] = random_matrix(rng, ns, nd, 0.1);
    b.B[j] = MatX::Zero(ns + extra, nu);
    b.B[j].topRows(ns) = a.B[j];
    b.E[j] = MatX::Zero(ns + extra, nd);
    b.E[j].topRows(ns) = a.E[j];
  }
  for (int step = 0; step < 8; ++step) {
    for (int j = 0; j < np; ++j) {
      a.A[j] = MatX::Zero(ns, ns);
      for (int k = 0; k < ns; ++k) {
        a.A[j](k, k) = 0.9 + 0.1 * unit(rng);
        if (k + 1 < ns) a.A[j](k, k + 1) = 0.1 + 0.1 * unit(rng);
      }
      b.A[j] = MatX::Zero(ns + extra, ns + extra);
      b.A[j].topLeftCorner(ns, ns) = a.A[j];
      b.A[j].bottomRightCorner(extra, extra) = 0.5 * MatX::Identity(extra, extra);
    }
    a.delta_state = random_matrix(rng, ns, 1, 0.05);
    a.state = random_matrix(rng, ns, 1, 5.0);
    a.output = a.C * a.state;
    a.reference = random_matrix(rng, ny, np, 3.0);
    a.disturbance_delta = random_matrix(rng, nd, np, 0.1);
    a.state_offset = random_matrix(rng, ns, np, 0.01);
    b.delta_state = VecX::Zero(ns + extra);
    b.delta_state.head(ns) = a.delta_state;
    b.state = VecX::Zero(ns + extra);
    b.state.head(ns) = a.state;
    b.output = a.output;
    b.reference = a.reference;
    b.disturbance_delta = a.disturbance_delta;
    b.state_offset = MatX::Zero(ns + extra, np);
    b.state_offset.topRows(ns) = a.state_offset;
    const IncrementalMpcResult& ra = small.solve();
    const IncrementalMpcResult& rb = large.solve();
    SCOPED_TRACE(step);
    ASSERT_TRUE(ra.solved());
    ASSERT_TRUE(rb.solved());
    EXPECT_TRUE(same_bits(ra.moves, rb.moves));
    EXPECT_TRUE(same_bits(ra.predicted_outputs, rb.predicted_outputs));
    EXPECT_TRUE(same_bits(ra.predicted_states, MatX(rb.predicted_states.topRows(ns))));
    EXPECT_GT(ra.moves.cwiseAbs().maxCoeff(), 0.0);  // the prediction depends on the moves
  }
}

// The solution's prediction rounds each product before adding it, as the baseline code did:
// in the AVX2 clone it is compiled without fused multiply-adds, so the default run's
// trajectories do not depend on the CPU. Checked against a simulation of the same sums with
// each product rounded on its own (a volatile store), on a plant without disturbances or
// offsets (its known terms are zero): Δs_j = (B_j Δu_j) + A_j Δs_{j−1}, s_j = s_{j−1} + Δs_j.
TEST(IncrementalMpcPrediction, SolutionPredictionRoundsEachProduct) {
#if !(defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__))
  GTEST_SKIP() << "only the x86-64 clones have contraction turned off";
#endif
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int ns = 7, nu = 3, ny = 3, np = 10, nc = 4;
  IncrementalMpcOptions o = basic_options(ny, nu, np, nc);
  o.move_weight = VecX::Constant(nu, 0.01);  // moves large enough to matter
  IncrementalMpc mpc(IncrementalMpcDims{ns, nu, ny, 1, 0, 0}, o);
  IncrementalMpcData& d = mpc.data();
  d.C = MatX::Zero(ny, ns);
  for (int k = 0; k < ny; ++k) d.C(k, k) = 1.0;
  for (int j = 0; j < np; ++j) {
    d.A[j] = MatX::Identity(ns, ns);
    for (int k = 0; k < ns; ++k) {
      if (k + 3 < ns) d.A[j](k, k + 3) = 0.1 + 0.3 * unit(rng);  // state k + 3 drives state k
    }
    d.A[j](0, 4) = 0.07 * unit(rng);
    d.B[j] = MatX::Zero(ns, nu);
    for (int c = 0; c < nu; ++c) d.B[j](ns - 1 - c, c) = 0.1 + 0.1 * unit(rng);
    d.E[j] = MatX::Zero(ns, 1);
  }
  d.delta_state = random_matrix(rng, ns, 1, 0.05);
  d.state = random_matrix(rng, ns, 1, 5.0);
  d.output = d.C * d.state;
  d.reference = random_matrix(rng, ny, np, 3.0);
  d.disturbance_delta = MatX::Zero(1, np);
  d.state_offset = MatX::Zero(ns, np);
  const IncrementalMpcResult& r = mpc.solve();
  ASSERT_TRUE(r.solved());
  ASSERT_GT(r.moves.cwiseAbs().minCoeff(), 0.0);
  const auto rounded = [](double a, double b) {
    volatile double p = a * b;  // stored: rounded before the sum that uses it
    return static_cast<double>(p);
  };
  VecX ds = d.delta_state, s = d.state;
  for (int j = 0; j < np; ++j) {
    VecX next(ns);
    for (int k = 0; k < ns; ++k) {
      double v = 0.0;
      if (j < nc) {
        double t = 0.0;
        for (int c = 0; c < nu; ++c) {
          if (d.B[j](k, c) != 0.0) t = t + rounded(d.B[j](k, c), r.moves[j * nu + c]);
        }
        v = v + t;
      }
      for (int l = 0; l < ns; ++l) {
        if (d.A[j](k, l) != 0.0) v = v + rounded(d.A[j](k, l), ds[l]);
      }
      next[k] = v;
    }
    ds = next;
    s = s + ds;
    SCOPED_TRACE(j);
    EXPECT_TRUE(same_bits(VecX(r.predicted_states.col(j)), s));
  }
}

// Soft rows that no move within the move limits can violate are left out of the QP; the
// solution must be the one of the QP with every row. The UAV's Jacobians along random
// nominals, rate-limited moves, and soft rows at random distances from the free response
// (half of them farther than the moves can reach in the horizon, some in reach, some
// violated by the free response) over a sequence of steps whose rows come and go, so that the
// hot start also meets rows that moved in the QP.
// The move box is the UAV's, symmetric (each row's range over it is one sum), and shifted
// (the general ends, a minimum and a maximum a term).
TEST(IncrementalMpcSoftRows, RedundantRowsLeftOutChangeNothing) {
  for (const bool symmetric : {true, false}) {
    SCOPED_TRACE(symmetric ? "symmetric move box" : "shifted move box");
    std::mt19937 rng(5);
    const int ns = vehicle::kStateDim, nu = vehicle::kInputDim, ny = 3, np = 40, nc = 10;
    IncrementalMpcOptions o = uav_options(np, nc);
    if (!symmetric) o.move_min *= 0.5;                                        // [−h/2, h]
    o.qp_settings = {.tolerance = 1e-7, .method = qp::QpMethod::kActiveSet};  // the tracker's
    IncrementalMpcOptions all_rows = o;
    all_rows.drop_redundant_soft_rows = false;
    const IncrementalMpcDims dims{ns, nu, ny, 3, 3 * np, 3};
    IncrementalMpc dropping(dims, o), keeping(dims, all_rows);
    std::uniform_real_distribution<double> heading(-kPi, kPi), unit(0.0, 1.0);
    int added = 0, carried = 0, active_rows = 0, exact_steps = 0;
    for (int step = 0; step < 30; ++step) {
      const std::uint32_t seed = rng();
      for (IncrementalMpc* mpc : {&dropping, &keeping}) {
        std::mt19937 data_rng(seed);
        IncrementalMpcData& d = mpc->data();
        const double psi0 = heading(data_rng);
        set_uav_plant(d, psi0, 0.02, 0.0);
        // Flying at 12 m/s along ψ0, the reference a few metres off the straight path.
        d.delta_state = random_matrix(data_rng, ns, 1, 0.02);
        d.delta_state[0] += 1.2 * std::cos(psi0);
        d.delta_state[1] += 1.2 * std::sin(psi0);
        d.output = random_matrix(data_rng, ny, 1, 50.0);
        d.state = random_matrix(data_rng, ns, 1, 50.0);
        d.reference = random_matrix(data_rng, ny, np, 3.0);
        for (int j = 0; j < np; ++j) {
          d.reference.col(j) += d.output + (j + 1) * d.delta_state.head<3>();
        }
        d.disturbance_delta.setZero();
        d.state_offset.setZero();
        mpc->build_prediction();
        d.clear_soft_rows();
        // Rows in (group, source, step) order; each source's rows start at a step that moves
        // from one solve to the next.
        for (int group = 0; group < 3; ++group) {
          for (int source = 0; source < 2; ++source) {
            const int first = static_cast<int>(unit(data_rng) * np / 2);
            for (int j = first; j < np; j += 2) {
              Vec3 a = random_matrix(data_rng, 3, 1, 1.0);
              a.normalize();
              const double free = a.dot(mpc->free_response().segment<3>(j * ny));
              // From 1 m violated to 40 m clear of the free response.
              const double clear = -1.0 + 41.0 * unit(data_rng);
              d.add_soft_row(j, a, free - clear, group, source);
            }
          }
        }
        mpc->solve();
      }
      const IncrementalMpcResult& a = dropping.last_result();
      const IncrementalMpcResult& b = keeping.last_result();
      SCOPED_TRACE(step);
      ASSERT_TRUE(a.solved()) << qp::to_string(a.qp_status);
      ASSERT_TRUE(b.solved()) << qp::to_string(b.qp_status);
      EXPECT_EQ(b.soft_rows_in_qp, keeping.data().soft_row_count);
      // The active set's answers are exact to round-off; where it handed a problem to the
      // interior point (some steps with violated rows), the answers agree to its tolerance.
      const bool exact = !dropping.qp_result().fell_back && !keeping.qp_result().fell_back;
      const double tolerance = exact ? 1e-9 : 1e-5;
      exact_steps += exact ? 1 : 0;
      EXPECT_LE((a.moves - b.moves).cwiseAbs().maxCoeff(), tolerance);
      EXPECT_LE((a.slack - b.slack).cwiseAbs().maxCoeff(), tolerance);
      EXPECT_NEAR(a.cost, b.cost, tolerance * std::max(1.0, std::abs(b.cost)));
      // Every row, carried or not, holds at the solution up to its slack.
      const IncrementalMpcData& d = dropping.data();
      for (int r = 0; r < d.soft_row_count; ++r) {
        const double lhs = d.soft_normal.col(r).dot(a.predicted_outputs.col(d.soft_step[r]));
        EXPECT_GE(lhs + a.slack[d.soft_group[r]], d.soft_bound[r] - 1e-6);
        if (lhs < d.soft_bound[r] + 1e-6) ++active_rows;
      }
      added += d.soft_row_count;
      carried += a.soft_rows_in_qp;
    }
    // Both kinds occur: rows left out, and rows carried of which some bind.
    EXPECT_LT(carried, added / 2);
    EXPECT_GT(carried, 0);
    EXPECT_GT(active_rows, 0);
    EXPECT_GE(exact_steps, 15);
  }
}

// A move box with infinite sides (the climb's here) still leaves out a row no move can reach:
// the climb command acts on the altitude through the climb rate, so no move changes step 0's
// altitude, and a row 5 m below its free response there cannot bind (its range over the box is
// [0, 0]: the zero entries add zero, not 0·∞). At step 5 the unbounded moves reach the altitude
// without limit: that row is carried. A finite box reads both the same way.
TEST(IncrementalMpcSoftRows, AnUnboundedMoveBoxLeavesOutRowsNoMoveReaches) {
  const int ns = vehicle::kStateDim, nu = vehicle::kInputDim, ny = 3, np = 10, nc = 4;
  for (const bool unbounded : {true, false}) {
    SCOPED_TRACE(unbounded);
    IncrementalMpcOptions o = uav_options(np, nc);
    if (unbounded) {
      o.move_min[2] = -qp::kInfinity;
      o.move_max[2] = qp::kInfinity;
    }
    o.qp_settings = {.tolerance = 1e-7, .method = qp::QpMethod::kActiveSet};
    IncrementalMpc mpc(IncrementalMpcDims{ns, nu, ny, 3, 4, 1}, o);
    IncrementalMpcData& d = mpc.data();
    const double psi0 = 0.4;
    set_uav_plant(d, psi0, 0.02, 0.0);
    d.delta_state = VecX::Zero(ns);
    d.delta_state[0] = 1.2 * std::cos(psi0);
    d.delta_state[1] = 1.2 * std::sin(psi0);
    d.state = VecX::Zero(ns);
    d.state[vehicle::kZ] = 100.0;
    d.state[vehicle::kPsi] = psi0;
    d.state[vehicle::kV] = 12.0;
    d.output = d.state.head<3>();
    for (int j = 0; j < np; ++j) d.reference.col(j) = d.output + (j + 1) * d.delta_state.head<3>();
    d.disturbance_delta.setZero();
    d.state_offset.setZero();
    mpc.build_prediction();
    const VecX free = mpc.free_response();
    d.clear_soft_rows();
    ASSERT_TRUE(d.add_soft_row(0, Vec3::UnitZ(), free[2] - 5.0, 0, 0));
    ASSERT_TRUE(d.add_soft_row(5, Vec3::UnitZ(), free[5 * ny + 2] - 5.0, 0, 0));
    const IncrementalMpcResult& r = mpc.solve();
    ASSERT_TRUE(r.solved()) << qp::to_string(r.qp_status);
    // Bounded, the climb's moves (0.1 m/s each) lift step 5 by far less than 5 m: left out too.
    EXPECT_EQ(r.soft_rows_in_qp, unbounded ? 1 : 0);
    EXPECT_EQ(r.max_slack, 0.0);
  }
}

TEST(IncrementalMpcOptionsCheck, RejectsInconsistentOptionsNamingTheField) {
  IncrementalMpcOptions o = basic_options(2, 1, 10, 12);
  try {
    IncrementalMpc mpc(IncrementalMpcDims{3, 1, 2, 0, 0, 0}, o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "options.control_horizon");
  }
  o = basic_options(2, 1, 10, 5);
  o.move_weight = VecX::Zero(1);
  EXPECT_THROW(IncrementalMpc(IncrementalMpcDims{3, 1, 2, 0, 0, 0}, o), InputError);
  o = basic_options(2, 1, 10, 5);
  EXPECT_THROW(IncrementalMpc(IncrementalMpcDims{3, 1, 2, 0, 4, 0}, o), InputError);
  o = basic_options(2, 1, 10, 5);
  o.input_min = VecX::Constant(1, 1.0);
  o.input_max = VecX::Constant(1, -1.0);
  try {
    IncrementalMpc mpc(IncrementalMpcDims{3, 1, 2, 0, 0, 0}, o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "options.input_min/options.input_max");
  }
}

TEST(IncrementalMpcData, WrongSizedDataIsReportedNotSolved) {
  IncrementalMpc mpc(IncrementalMpcDims{3, 1, 2, 0, 0, 0}, basic_options(2, 1, 10, 5));
  mpc.data().A[4] = MatX::Identity(2, 2);
  const IncrementalMpcResult& r = mpc.solve();
  EXPECT_EQ(r.qp_status, qp::QpStatus::kInvalidInput);
  EXPECT_EQ(r.invalid_field, "A[j]");
}

// Soft rows written into the data directly (not through add_soft_row) are checked too: each
// bad index is named, wherever it sits among good rows, and good rows pass.
TEST(IncrementalMpcData, BadSoftRowIndicesAreNamed) {
  const auto solve_with = [](int bad_row, const char* field, int value) {
    IncrementalMpc mpc(IncrementalMpcDims{3, 1, 2, 0, 9, 2}, basic_options(2, 1, 10, 5));
    IncrementalMpcData& d = mpc.data();
    for (int r = 0; r < 9; ++r) {
      EXPECT_TRUE(d.add_soft_row(r, Eigen::Vector2d(1.0, 0.0), -100.0, r % 2, r));
    }
    if (bad_row >= 0) {
      std::vector<int>& target = std::string(field) == "soft_step"    ? d.soft_step
                                 : std::string(field) == "soft_group" ? d.soft_group
                                                                      : d.soft_source;
      target[static_cast<std::size_t>(bad_row)] = value;
    }
    return std::string(mpc.solve().invalid_field);
  };
  EXPECT_EQ(solve_with(-1, "", 0), "");
  for (int row : {0, 4, 8}) {  // the first row, one in the middle, the last
    EXPECT_EQ(solve_with(row, "soft_step", -1), "soft_step") << row;
    EXPECT_EQ(solve_with(row, "soft_step", 10), "soft_step") << row;  // Np is 10
    EXPECT_EQ(solve_with(row, "soft_group", 2), "soft_group") << row;
    EXPECT_EQ(solve_with(row, "soft_group", -3), "soft_group") << row;
    EXPECT_EQ(solve_with(row, "soft_source", -1), "soft_source") << row;
  }
  EXPECT_EQ(solve_with(5, "soft_step", 9), "");  // the last step and group are in range
  EXPECT_EQ(solve_with(5, "soft_group", 1), "");
}

// ---------------------------------------------------------------------------------------
// Linear longitudinal aircraft model (small perturbations about a 60 m/s cruise, stability
// axes), textbook structure (e.g. Nelson, "Flight Stability and Automatic Control", ch. 4–5)
// with illustrative light-transport coefficients:
//   state x = [V (m/s), α (rad), q (rad/s), θ (rad), P (m/s², thrust per unit mass), γ (rad)]
//   input u = [δ_t (throttle, normalized), δ_e (elevator, rad)]
//   V̇ = X_u V + X_α α − g θ + P          (drag, lift-tilt, gravity along the path, thrust)
//   α̇ = Z_u V + Z_α α + q + Z_δe δ_e      (Z's already divided by V0)
//   q̇ = M_α α + M_q q + M_δe δ_e          (short period ω ≈ 4.2 rad/s, ζ ≈ 0.6)
//   θ̇ = q
//   Ṗ = (k_t δ_t − P)/τ_P                 (first-order engine lag)
//   γ̇ = θ̇ − α̇                            (γ = θ − α kept as a state: the tracked output)
// Discretized exactly for a zero-order-hold input with the matrix exponential of
// [A B; 0 0]·Δt (Van Loan).
struct AircraftCoefficients {
  double Xu = -0.045, Xa = 1.9, Zu = -0.003, Za = -2.0, Zde = -0.16;
  double Ma = -12.0, Mq = -3.0, Mde = -11.0, kt = 5.0, tauP = 0.8;
};

void aircraft_continuous(const AircraftCoefficients& c, MatX& A, MatX& B) {
  A = MatX::Zero(6, 6);
  B = MatX::Zero(6, 2);
  A(0, 0) = c.Xu;
  A(0, 1) = c.Xa;
  A(0, 3) = -kGravity_m_s2;
  A(0, 4) = 1.0;
  A(1, 0) = c.Zu;
  A(1, 1) = c.Za;
  A(1, 2) = 1.0;
  B(1, 1) = c.Zde;
  A(2, 1) = c.Ma;
  A(2, 2) = c.Mq;
  B(2, 1) = c.Mde;
  A(3, 2) = 1.0;
  A(4, 4) = -1.0 / c.tauP;
  B(4, 0) = c.kt / c.tauP;
  A.row(5) = A.row(3) - A.row(1);
  B.row(5) = B.row(3) - B.row(1);
}

void zoh(const MatX& Ac, const MatX& Bc, double dt, MatX& Ad, MatX& Bd) {
  const int n = static_cast<int>(Ac.rows()), m = static_cast<int>(Bc.cols());
  MatX M = MatX::Zero(n + m, n + m);
  M.topLeftCorner(n, n) = Ac * dt;
  M.topRightCorner(n, m) = Bc * dt;
  const MatX Md = M.exp();
  Ad = Md.topLeftCorner(n, n);
  Bd = Md.topRightCorner(n, m);
}

constexpr double kAircraftDt = 0.1;
constexpr double kThrottleMax = 0.5, kElevatorMax = 0.35;   // |δ_t|, |δ_e| (rad)
constexpr double kThrottleRate = 0.5, kElevatorRate = 1.0;  // per second

struct AircraftLoop {
  IncrementalMpc mpc;
  MatX Ad, Bd, C;

  explicit AircraftLoop(int soft_capacity, bool hard_output_limits = false)
      : mpc(IncrementalMpcDims{6, 2, 2, 0, soft_capacity, soft_capacity > 0 ? 1 : 0},
            make_options(hard_output_limits)) {
    MatX Ac, Bc;
    aircraft_continuous(AircraftCoefficients{}, Ac, Bc);
    zoh(Ac, Bc, kAircraftDt, Ad, Bd);
    C = MatX::Zero(2, 6);
    C(0, 0) = 1.0;
    C(1, 5) = 1.0;
    IncrementalMpcData& d = mpc.data();
    d.set_time_invariant(Ad, Bd, C, MatX());
  }

  static IncrementalMpcOptions make_options(bool hard_output_limits) {
    IncrementalMpcOptions o;
    o.hard_output_limits = hard_output_limits;
    o.prediction_horizon = 50;
    o.control_horizon = 8;
    // 1 m/s of speed error weighs like 0.01 rad (0.6°) of flight-path error.
    o.output_weight = (VecX(2) << 1.0, 1e4).finished();
    o.move_weight = (VecX(2) << 10.0, 10.0).finished();
    // Exact penalty: ρ₁ must exceed the sum of the multipliers of a group's rows. A 0.02 rad
    // flight-path error costs 2·1e4·0.02 = 400 per step, over 50 steps 2·10⁴; 10⁶ is safe.
    o.slack_linear_weight = 1e6;
    o.input_min = Eigen::Vector2d(-kThrottleMax, -kElevatorMax);
    o.input_max = -o.input_min;
    o.move_min = Eigen::Vector2d(-kThrottleRate * kAircraftDt, -kElevatorRate * kAircraftDt);
    o.move_max = -o.move_min;
    return o;
  }
};

// The truth differs from the controller's model: coefficients off by 10–30 % and an
// unmodelled constant drag (−0.4 m/s²). The incremental form must still remove the steady-state
// error of both outputs, and the input and rate limits must hold at every step.
TEST(IncrementalMpcAircraft, TracksStepsInSpeedAndFlightPathWithZeroSteadyStateError) {
  AircraftLoop loop(0);
  AircraftCoefficients truth;
  truth.Xu *= 1.3;
  truth.Ma *= 1.15;
  truth.Mde *= 0.85;
  truth.kt *= 0.8;
  truth.tauP *= 1.25;
  MatX Ac, Bc, At, Bt;
  aircraft_continuous(truth, Ac, Bc);
  zoh(Ac, Bc, kAircraftDt, At, Bt);
  VecX drag = VecX::Zero(6);
  drag[0] = -0.4 * kAircraftDt;  // first-order effect of a constant deceleration over one step

  VecX x = VecX::Zero(6), x_prev = VecX::Zero(6), u = VecX::Zero(2);
  IncrementalMpcData& d = loop.mpc.data();
  double max_throttle_move = 0.0;
  const int steps = 800;  // 80 s
  for (int k = 0; k < steps; ++k) {
    const double t = k * kAircraftDt;
    const Eigen::Vector2d r = t < 40.0 ? Eigen::Vector2d(5.0, 0.05) : Eigen::Vector2d(-3.0, -0.03);
    for (int j = 0; j < d.reference.cols(); ++j) d.reference.col(j) = r;
    d.delta_state = x - x_prev;
    d.output = loop.C * x;
    d.state = x;
    d.previous_input = u;
    const IncrementalMpcResult& res = loop.mpc.solve();
    ASSERT_TRUE(res.solved()) << "step " << k << ": " << qp::to_string(res.qp_status);
    const VecX u_new = res.first_input;
    // Interior-point iterates satisfy the limits to the solver tolerance (1e-9 relative);
    // 1e-7 absolute leaves room for the scale of the data.
    EXPECT_LE(std::abs(u_new[0]), kThrottleMax + 1e-7) << k;
    EXPECT_LE(std::abs(u_new[1]), kElevatorMax + 1e-7) << k;
    EXPECT_LE(std::abs(u_new[0] - u[0]), kThrottleRate * kAircraftDt + 1e-7) << k;
    EXPECT_LE(std::abs(u_new[1] - u[1]), kElevatorRate * kAircraftDt + 1e-7) << k;
    max_throttle_move = std::max(max_throttle_move, std::abs(u_new[0] - u[0]));
    u = u_new;
    x_prev = x;
    x = At * x + Bt * u + drag;
    if (k == 399 || k == steps - 1) {
      // The error decays geometrically (measured: about 10× every 2 s, down to rounding by
      // ~30 s after each step); a bias from the drag or the 10–30 % model error would stay. So
      // 1e-7 m/s and 1e-9 rad ask for zero up to the QP's tolerance (1e-9 relative), i.e. for
      // no bias at all.
      EXPECT_NEAR(x[0], r[0], 1e-7) << "t = " << t;
      EXPECT_NEAR(x[5], r[1], 1e-9) << "t = " << t;
    }
  }
  // The throttle rate limit was active (the test exercises the limits, not just respects them).
  EXPECT_GT(max_throttle_move, 0.99 * kThrottleRate * kAircraftDt);
}

// A soft output constraint γ ≤ 0.03 rad against a reference of 0.05 rad: the output settles on
// the constraint, and the slack stays at zero because the constraint can be met. A second,
// unreachable soft constraint (V ≥ 200 m/s within the horizon) leaves the QP solvable and
// reports the violation in the slack.
TEST(IncrementalMpcAircraft, SoftOutputConstraintsHoldAndReportViolations) {
  AircraftLoop loop(100);
  IncrementalMpcData& d = loop.mpc.data();
  VecX x = VecX::Zero(6), x_prev = VecX::Zero(6), u = VecX::Zero(2);
  const Eigen::Vector2d a_gamma(0.0, -1.0);  // −γ ≥ −0.03
  double max_gamma = -1.0;
  for (int k = 0; k < 300; ++k) {
    d.reference.row(0).setConstant(0.0);
    d.reference.row(1).setConstant(0.05);
    d.clear_soft_rows();
    for (int j = 0; j < d.reference.cols(); ++j) ASSERT_TRUE(d.add_soft_row(j, a_gamma, -0.03, 0));
    d.delta_state = x - x_prev;
    d.output = loop.C * x;
    d.previous_input = u;
    const IncrementalMpcResult& res = loop.mpc.solve();
    ASSERT_TRUE(res.solved()) << k << ": " << qp::to_string(res.qp_status);
    // The exact penalty (ρ₁ = 1e6 ≫ the multipliers the tracking cost puts on γ) keeps σ = 0
    // when feasible; the IPM leaves σ at its tolerance level.
    EXPECT_LT(res.max_slack, 1e-6) << k;
    u = res.first_input;
    x_prev = x;
    x = loop.Ad * x + loop.Bd * u;
    if (k > 150) max_gamma = std::max(max_gamma, x[5]);
  }
  // The plant is the model here, so the constraint holds up to the solver tolerance.
  EXPECT_LT(max_gamma, 0.03 + 1e-6);
  EXPECT_GT(max_gamma, 0.03 - 1e-3);  // and it is active: the output rides the constraint

  d.clear_soft_rows();
  ASSERT_TRUE(d.add_soft_row(49, Eigen::Vector2d(1.0, 0.0), 200.0, 0));
  const IncrementalMpcResult& res = loop.mpc.solve();
  ASSERT_TRUE(res.solved());
  // The throttle can add at most ~5 m/s² for 5 s: V cannot exceed ~30 m/s, so ≥ 150 m/s of
  // slack must be reported.
  EXPECT_GT(res.max_slack, 150.0);
  EXPECT_NEAR(res.predicted_outputs(0, 49) + res.slack[0], 200.0, 1e-5);
}

// Hard output limit of eq. 11 (γ ≤ 0.03 rad as a row y ≤ y_max) against a 0.05 rad reference:
// the nominal plant (model = plant) never exceeds it beyond the solver tolerance and rides it.
TEST(IncrementalMpcAircraft, HardOutputLimitHolds) {
  AircraftLoop loop(0, /*hard_output_limits=*/true);
  IncrementalMpcData& d = loop.mpc.data();
  d.output_max.row(1).setConstant(0.03);
  d.reference.row(0).setConstant(0.0);
  d.reference.row(1).setConstant(0.05);
  VecX x = VecX::Zero(6), x_prev = VecX::Zero(6), u = VecX::Zero(2);
  double max_gamma = -1.0;
  for (int k = 0; k < 300; ++k) {
    d.delta_state = x - x_prev;
    d.output = loop.C * x;
    d.previous_input = u;
    const IncrementalMpcResult& res = loop.mpc.solve();
    ASSERT_TRUE(res.solved()) << k << ": " << qp::to_string(res.qp_status);
    u = res.first_input;
    x_prev = x;
    x = loop.Ad * x + loop.Bd * u;
    max_gamma = std::max(max_gamma, x[5]);
  }
  EXPECT_LT(max_gamma, 0.03 + 1e-6);  // the solver meets rows to ~1e-9 relative
  EXPECT_GT(max_gamma, 0.03 - 1e-3);
  EXPECT_EQ(loop.mpc.num_rows(), 8 * 2 + 50 * 2);  // input rows + output rows, no soft rows
}

}  // namespace
}  // namespace ridgeline::mpc
