// Ipopt as an independent reference solver for QpProblem: the cross-check in the tests and the
// yardstick in `ridgeline bench` (never the solver that flies).
//
// The QP is handed to Ipopt through its TNLP interface as a general NLP with constant
// Hessian H (lower triangle, dense), constant dense Jacobian [G; A], variable bounds lb ≤ z ≤ ub
// and constraint bounds lg ≤ Gz ≤ ug, b ≤ Az ≤ b. Ipopt runs with adaptive μ and the
// "constant" hints; at tol 1e-10 its answer is accurate far below the tests' 1e-6 tolerances.
#pragma once

#include <coin/IpReturnCodes.hpp>

#include <Eigen/Core>

#include "qp/qp_solver.hpp"

namespace ridgeline::qp {

struct IpoptQpSolution {
  Ipopt::ApplicationReturnStatus status = Ipopt::Internal_Error;
  Eigen::VectorXd z;
  double objective = 0.0;
  int iterations = 0;
  double solve_time_us = 0.0;  ///< OptimizeTNLP alone (set-up of the application excluded)

  bool solved() const {
    return status == Ipopt::Solve_Succeeded || status == Ipopt::Solved_To_Acceptable_Level;
  }
};

/// Solves `problem` with Ipopt (silent). `bound_relax_factor` is Ipopt's option of that name
/// (its default 1e-8 relaxes every bound by that much relative, which shifts the objective of a
/// QP with active sides by ~1e-8·Σλ|b|; 0 solves the problem as given).
IpoptQpSolution solve_with_ipopt(const QpProblem& problem, double tolerance = 1e-10,
                                 double bound_relax_factor = 1e-8);

}  // namespace ridgeline::qp
