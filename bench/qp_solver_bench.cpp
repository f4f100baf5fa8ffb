// QP solver timings on MPC-like problems (DESIGN §3), cold and warm-started.
//
// BM_QpSolverSyntheticMpc: a condensed tracking QP built here — 30 variables (10 moves × 3
// inputs) with move bounds, 190 two-sided rows (input limits and an output box along a 40-step
// horizon) — whose reference moves a little every 20 ms, solved in sequence.
// BM_QpSolverInstanceFile: the instances of an RLQP file (gen_mpc_qps.py, see
// /work/shared/qp/README.md) named by the environment variable RIDGELINE_QP_INSTANCES.
// Both report the mean iterations per solve as a counter; arguments: warm (0/1) and method
// (0 interior point, 1 active set with hot start). Never gates CI on wall-clock time.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <vector>

#include <Eigen/Dense>

#include "qp/qp_instance_file.hpp"
#include "qp/qp_solver.hpp"

namespace {

using ridgeline::qp::QpProblem;
using ridgeline::qp::QpSettings;
using ridgeline::qp::QpSolver;
using ridgeline::qp::QpStatus;

// Single-integrator-like condensed prediction: output j depends on the cumulative moves.
std::vector<QpProblem> synthetic_mpc_sequence(int count) {
  constexpr int kMoves = 10, kInputs = 3, kHorizon = 40;
  const int n = kMoves * kInputs;
  Eigen::MatrixXd Phi = Eigen::MatrixXd::Zero(kHorizon * kInputs, n);
  for (int j = 0; j < kHorizon; ++j) {
    for (int i = 0; i < std::min(j + 1, kMoves); ++i) {
      Phi.block(kInputs * j, kInputs * i, kInputs, kInputs) =
          0.1 * (j - i + 1) * Eigen::Matrix3d::Identity();
    }
  }
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, n);  // inputs = cumulative moves
  for (int i = 0; i < kMoves; ++i) {
    for (int k = 0; k <= i; ++k) L.block(kInputs * i, kInputs * k, kInputs, kInputs).setIdentity();
  }
  QpProblem base;
  base.H = 2.0 * (Phi.transpose() * Phi + 0.1 * Eigen::MatrixXd::Identity(n, n));
  base.lb = Eigen::VectorXd::Constant(n, -1.0);
  base.ub = Eigen::VectorXd::Constant(n, 1.0);
  base.G.resize(n + Phi.rows() + 40, n);
  base.G << L, Phi, Phi.topRows(40);  // 30 + 120 + 40 = 190 rows
  base.lg.resize(base.G.rows());
  base.ug.resize(base.G.rows());
  base.A.resize(0, n);
  std::vector<QpProblem> out;
  for (int k = 0; k < count; ++k) {
    QpProblem q = base;
    const double t = 0.02 * k;
    Eigen::VectorXd ref(Phi.rows());
    for (int i = 0; i < ref.size(); ++i) ref[i] = 8.0 * std::sin(0.5 * t + 0.05 * i);
    q.f = -2.0 * Phi.transpose() * ref;
    q.lg.head(n).setConstant(-3.0);
    q.ug.head(n).setConstant(3.0);
    q.lg.segment(n, Phi.rows()).setConstant(-4.0 - std::sin(t));
    q.ug.segment(n, Phi.rows()).setConstant(4.0 + std::cos(t));
    q.lg.tail(40).setConstant(-ridgeline::qp::kInfinity);
    q.ug.tail(40).setConstant(3.0);
    out.push_back(std::move(q));
  }
  return out;
}

void run_sequence(benchmark::State& state, const std::vector<QpProblem>& problems) {
  QpSettings settings;
  settings.warm_start = state.range(0) != 0;
  settings.method = state.range(1) != 0 ? ridgeline::qp::QpMethod::kActiveSet
                                        : ridgeline::qp::QpMethod::kInteriorPoint;
  QpSolver solver(settings);
  std::size_t k = 0;
  long iterations = 0, solves = 0, failures = 0;
  for (auto _ : state) {
    const auto& r = solver.solve(problems[k]);
    benchmark::DoNotOptimize(r.objective);
    iterations += r.iterations;
    failures += r.status == QpStatus::kSolved ? 0 : 1;
    ++solves;
    k = (k + 1) % problems.size();
    if (k == 0) solver.reset();  // the sequence restarts: do not warm start across the jump
  }
  state.counters["iterations"] = static_cast<double>(iterations) / std::max(1L, solves);
  state.counters["failures"] = static_cast<double>(failures);
}

void BM_QpSolverSyntheticMpc(benchmark::State& state) {
  static const std::vector<QpProblem> problems = synthetic_mpc_sequence(500);
  run_sequence(state, problems);
}
BENCHMARK(BM_QpSolverSyntheticMpc)->ArgsProduct({{0, 1}, {0, 1}})
    ->ArgNames({"warm", "active_set"})
    ->Unit(benchmark::kMicrosecond);

void BM_QpSolverInstanceFile(benchmark::State& state) {
  const char* path = std::getenv("RIDGELINE_QP_INSTANCES");
  if (path == nullptr) {
    state.SkipWithError("set RIDGELINE_QP_INSTANCES to an RLQP file (gen_mpc_qps.py)");
    return;
  }
  static const std::vector<QpProblem> problems = ridgeline::qp::read_qp_instance_file(path);
  run_sequence(state, problems);
}
BENCHMARK(BM_QpSolverInstanceFile)->ArgsProduct({{0, 1}, {0, 1}})
    ->ArgNames({"warm", "active_set"})
    ->Unit(benchmark::kMicrosecond);

}  // namespace
