// One Ipopt solve of a TrajectoryNlp (trajectory_nlp.hpp), shared by the joint optimizer
// (trajectory_optimizer.hpp) and the local re-plan (local_replan.hpp): the TNLP adapter, the
// solver options both use (our KKT factorization, kkt_ldlt.hpp, or MUMPS; user row scaling;
// monotone barrier; no options file) and the warm start from a previous solve's multipliers.
#pragma once

#include <vector>

#include "planning/trajectory_nlp.hpp"
#include "planning/trajectory_optimizer.hpp"

namespace ridgeline::planning::detail {

/// Bound and row multipliers of a solve, to warm-start the next one.
struct Multipliers {
  std::vector<double> z_lower;
  std::vector<double> z_upper;
  std::vector<double> lambda;
  bool empty() const { return lambda.empty() && z_lower.empty(); }
};

struct IpoptSolve {
  /// kSolved (Ipopt's success or acceptable point), kInfeasible, kIterationLimit, kTimeLimit or
  /// kSolverError (which includes a failed initialization).
  TrajectoryStatus status = TrajectoryStatus::kSolverError;
  std::vector<double> x;    ///< the last iterate (x0 when Ipopt did not start)
  Multipliers multipliers;  ///< at the last iterate
  int iterations = 0;
  double solve_time_s = 0.0;  ///< wall time of OptimizeTNLP
};

/// Solves `nlp` from x0 (size num_variables). With non-empty `warm` (sizes of this NLP) Ipopt
/// starts from those multipliers with barrier parameter options.warm_start_mu. Uses
/// options.tolerance, constraint_tolerance, max_iterations, exact_hessian, lbfgs_history,
/// adaptive_barrier, kkt_factorization, print_level; max_cpu_time_s > 0 bounds the solve in CPU
/// seconds of the calling thread (then kTimeLimit).
IpoptSolve solve_with_ipopt(const TrajectoryNlp& nlp, std::vector<double> x0,
                            const Multipliers& warm, const TrajectoryOptimizerOptions& options,
                            double max_cpu_time_s);

}  // namespace ridgeline::planning::detail
