// `ridgeline bench qp`: times QpSolver on a sequence of QP instances (an RLQP file, see
// qp/qp_instance_file.hpp), solved in order and hot/warm-started from the previous solve as the
// MPC does, against the floor of an unconstrained Cholesky solve of the same instances in the
// same run and checked against a tight reference solve outside the timed region.
//
// The ratio solve_us.median / floor_llt_us.median is the figure to compare across machines:
// absolute times vary by ±30 % from run to run on shared machines. The sequence is solved
// `repeats` times from a fresh solver (the same computation each pass: a solve is
// deterministic) and each instance's time is its minimum over the passes, which removes the
// preemptions of a shared machine (one 5 ms time slice in 1000 solves moves the p99) but not
// the solver's own slow instances. The thread CPU time of the first pass is reported too.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "benchmarks/host_speed.hpp"
#include "mission/statistics.hpp"
#include "qp/qp_solver.hpp"

namespace ridgeline::benchmarks {

enum class QpReference {
  kIpopt,          ///< Ipopt at tol 1e-10, bound_relax_factor 0 (independent of our code)
  kInteriorPoint,  ///< our interior point at tolerance 1e-10, cold, polished
  kNone,           ///< no accuracy check (max_rel_objective_gap stays 0): quick timing runs
};

struct QpBenchmarkOptions {
  /// The solver under test. Default: the MPC's active-set method at the default tolerance.
  qp::QpSettings settings{.method = qp::QpMethod::kActiveSet};
  QpReference reference = QpReference::kIpopt;
  int repeats = 3;  ///< passes over the sequence, ≥ 1
};

struct QpBenchmarkReport {
  int count = 0;
  int repeats = 0;
  mission::Percentiles solve_us;  ///< QpSolver::solve, wall clock, per instance (min over passes)
  mission::Percentiles solve_cpu_us;  ///< the same in thread CPU time, first pass
  mission::Percentiles
      iterations;              ///< active-set sides added/dropped (+ interior-point iterations)
  std::vector<int> failures;   ///< indices of instances not reported kSolved
  int fallbacks = 0;           ///< instances the interior point answered after the active set
  int nondeterministic = 0;    ///< later passes whose objective differed from the first's
  double max_violation = 0.0;  ///< largest violation of a bound or row, absolute
  double max_rel_objective_gap = 0.0;  ///< |J − J_ref| / max(1, |J_ref|) over the instances
  int reference_failures = 0;          ///< instances the reference did not solve (no gap)
  double floor_llt_us_median = 0.0;    ///< LLT factor + solve of Hz = −f, same instances
  std::string method;
  std::string reference;
  HostSpeed host_speed;  ///< read before and after the timed passes

  nlohmann::json to_json() const;
};

/// Solves `instances` in order with one QpSolver (so each solve starts from the previous one).
QpBenchmarkReport run_qp_benchmark(const std::vector<qp::QpProblem>& instances,
                                   const QpBenchmarkOptions& options = {});

}  // namespace ridgeline::benchmarks
