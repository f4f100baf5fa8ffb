#include "benchmarks/qp_benchmark.hpp"

#include <time.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "qp/ipopt_reference.hpp"

namespace ridgeline::benchmarks {
namespace {

using Clock = std::chrono::steady_clock;

double elapsed_us(Clock::time_point start) {
  return std::chrono::duration<double, std::micro>(Clock::now() - start).count();
}

double thread_cpu_us() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e6 + static_cast<double>(ts.tv_nsec) * 1e-3;
}

// Largest violation of a finite side, measured on the data (not taken from the solver).
double violation(const qp::QpProblem& q, const Eigen::VectorXd& z) {
  double worst = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (q.lb.size() != 0 && std::isfinite(q.lb[i])) worst = std::max(worst, q.lb[i] - z[i]);
    if (q.ub.size() != 0 && std::isfinite(q.ub[i])) worst = std::max(worst, z[i] - q.ub[i]);
  }
  if (q.G.rows() > 0) {
    const Eigen::VectorXd gz = q.G * z;
    for (Eigen::Index j = 0; j < gz.size(); ++j) {
      if (std::isfinite(q.lg[j])) worst = std::max(worst, q.lg[j] - gz[j]);
      if (std::isfinite(q.ug[j])) worst = std::max(worst, gz[j] - q.ug[j]);
    }
  }
  if (q.A.rows() > 0) worst = std::max(worst, (q.A * z - q.b).cwiseAbs().maxCoeff());
  return worst;
}

}  // namespace

nlohmann::json QpBenchmarkReport::to_json() const {
  return {{"count", count},
          {"method", method},
          {"repeats", repeats},
          {"solve_us", mission::to_json(solve_us)},
          {"solve_cpu_us", mission::to_json(solve_cpu_us)},
          {"iterations", {{"median", iterations.median}, {"max", iterations.max}}},
          {"failures", {{"count", failures.size()}, {"indices", failures}}},
          {"fallbacks", fallbacks},
          {"nondeterministic", nondeterministic},
          {"max_violation", max_violation},
          {"max_rel_objective_gap", max_rel_objective_gap},
          {"reference", reference},
          {"reference_failures", reference_failures},
          {"floor_llt_us", {{"median", floor_llt_us_median}}},
          {"median_over_floor",
           floor_llt_us_median > 0.0 ? solve_us.median / floor_llt_us_median : 0.0},
          {"p99_over_median", solve_us.median > 0.0 ? solve_us.p99 / solve_us.median : 0.0},
          {"host_speed", host_speed.to_json()}};
}

QpBenchmarkReport run_qp_benchmark(const std::vector<qp::QpProblem>& instances,
                                   const QpBenchmarkOptions& options) {
  QpBenchmarkReport report;
  report.count = static_cast<int>(instances.size());
  report.method = std::string(qp::to_string(options.settings.method));
  report.reference =
      options.reference == QpReference::kIpopt           ? "ipopt tol 1e-10, bound_relax_factor 0"
      : options.reference == QpReference::kInteriorPoint ? "interior point tol 1e-10, cold"
                                                         : "none";
  report.repeats = std::max(1, options.repeats);
  const std::size_t count = instances.size();
  std::vector<double> solve_us(count, qp::kInfinity), cpu_us(count), floor_us(count, qp::kInfinity);
  std::vector<double> iterations, objectives;
  std::vector<Eigen::VectorXd> solutions;
  std::vector<bool> solved;
  solutions.reserve(count);
  Eigen::LLT<Eigen::MatrixXd> llt;
  Eigen::VectorXd x;
  report.host_speed.read_before();
  for (int pass = 0; pass < report.repeats; ++pass) {
    qp::QpSolver solver(options.settings);
    for (std::size_t k = 0; k < count; ++k) {
      const qp::QpProblem& q = instances[k];
      const double cpu_start = thread_cpu_us();
      const auto start = Clock::now();
      const qp::QpResult& r = solver.solve(q);
      solve_us[k] = std::min(solve_us[k], elapsed_us(start));
      if (pass == 0) {
        cpu_us[k] = thread_cpu_us() - cpu_start;
        iterations.push_back(r.iterations);
        report.fallbacks += r.fell_back ? 1 : 0;
        solved.push_back(r.status == qp::QpStatus::kSolved);
        if (!solved.back()) report.failures.push_back(static_cast<int>(k));
        solutions.push_back(r.z);
        objectives.push_back(r.objective);
      } else if (r.objective != objectives[k]) {
        ++report.nondeterministic;
      }

      // The floor: the unconstrained problem of the same instance (storage sized beforehand).
      if (llt.rows() != q.H.rows()) {
        llt = Eigen::LLT<Eigen::MatrixXd>(q.H.rows());
        x.resize(q.H.rows());
      }
      const auto floor_start = Clock::now();
      llt.compute(q.H);
      x = -q.f;
      llt.solveInPlace(x);
      floor_us[k] = std::min(floor_us[k], elapsed_us(floor_start));
    }
  }
  report.host_speed.read_after();
  // Accuracy, outside the timed region.
  qp::QpSolver reference_solver(qp::QpSettings{.tolerance = 1e-10, .warm_start = false});
  for (std::size_t k = 0; k < instances.size(); ++k) {
    if (solved[k]) {
      report.max_violation = std::max(report.max_violation, violation(instances[k], solutions[k]));
    }
    if (!solved[k] || options.reference == QpReference::kNone) continue;
    const qp::QpProblem& q = instances[k];
    bool ok = false;
    double reference_objective = 0.0;
    if (options.reference == QpReference::kIpopt) {
      const qp::IpoptQpSolution ref = qp::solve_with_ipopt(q, 1e-10, 0.0);
      ok = ref.solved();
      reference_objective = ref.objective;
    } else {
      const qp::QpResult& ref = reference_solver.solve(q);
      ok = ref.status == qp::QpStatus::kSolved;
      reference_objective = ref.objective;
    }
    if (!ok) {
      ++report.reference_failures;
      continue;
    }
    report.max_rel_objective_gap =
        std::max(report.max_rel_objective_gap, std::abs(objectives[k] - reference_objective) /
                                                   std::max(1.0, std::abs(reference_objective)));
  }
  report.solve_us = mission::percentiles(solve_us);
  report.solve_cpu_us = mission::percentiles(cpu_us);
  report.iterations = mission::percentiles(iterations);
  report.floor_llt_us_median = mission::percentiles(floor_us).median;
  return report;
}

}  // namespace ridgeline::benchmarks
