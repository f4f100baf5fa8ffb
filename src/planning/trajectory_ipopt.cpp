#include "planning/trajectory_ipopt.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpSolveStatistics.hpp>
#include <coin/IpTNLP.hpp>
#include <optional>
#include <string>

#include "core/cpu_clock.hpp"
#include "planning/kkt_ldlt.hpp"

namespace ridgeline::planning::detail {
namespace {

// Ipopt adapter around the solver-independent transcription.
class IpoptAdapter : public Ipopt::TNLP {
 public:
  /// cpu_deadline_s: the calling thread's CPU time (thread_cpu_time_s) at which the solve
  /// stops; infinite: none.
  IpoptAdapter(const TrajectoryNlp& nlp, std::vector<double> x0, bool exact_hessian,
               Multipliers warm, double cpu_deadline_s)
      : nlp_(nlp),
        x0_(std::move(x0)),
        x_(x0_),
        exact_hessian_(exact_hessian),
        warm_(std::move(warm)),
        cpu_deadline_s_(cpu_deadline_s) {}

  const std::vector<double>& x() const { return x_; }
  const Multipliers& multipliers() const { return final_; }
  Ipopt::SolverReturn status() const { return status_; }
  bool out_of_time() const { return out_of_time_; }

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac, Ipopt::Index& nnz_h,
                    IndexStyleEnum& style) override {
    n = nlp_.num_variables();
    m = nlp_.num_constraints();
    nnz_jac = nlp_.jacobian_nonzeros();
    nnz_h = exact_hessian_ ? nlp_.hessian_nonzeros() : 0;
    style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Ipopt::Index, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index,
                       Ipopt::Number* g_l, Ipopt::Number* g_u) override {
    nlp_.bounds(x_l, x_u, g_l, g_u);
    return true;
  }
  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool init_z,
                          Ipopt::Number* z_l, Ipopt::Number* z_u, Ipopt::Index m, bool init_lambda,
                          Ipopt::Number* lambda) override {
    if (!init_x) return false;
    if ((init_z || init_lambda) && (static_cast<Ipopt::Index>(warm_.z_lower.size()) != n ||
                                    static_cast<Ipopt::Index>(warm_.lambda.size()) != m))
      return false;
    std::copy(x0_.begin(), x0_.begin() + n, x);
    if (init_z) {
      std::copy(warm_.z_lower.begin(), warm_.z_lower.end(), z_l);
      std::copy(warm_.z_upper.begin(), warm_.z_upper.end(), z_u);
    }
    if (init_lambda) std::copy(warm_.lambda.begin(), warm_.lambda.end(), lambda);
    return true;
  }
  bool get_scaling_parameters(Ipopt::Number& obj_scaling, bool& use_x_scaling, Ipopt::Index,
                              Ipopt::Number*, bool& use_g_scaling, Ipopt::Index,
                              Ipopt::Number* g_scaling) override {
    obj_scaling = 1.0;
    use_x_scaling = false;
    use_g_scaling = true;
    nlp_.row_scaling(g_scaling);
    return true;
  }
  bool eval_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number& f) override {
    f = nlp_.objective(x);
    return std::isfinite(f);
  }
  bool eval_grad_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number* g) override {
    nlp_.gradient(x, g);
    return true;
  }
  bool eval_g(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Index, Ipopt::Number* g) override {
    nlp_.constraints(x, g);
    return true;
  }
  bool eval_jac_g(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Index, Ipopt::Index,
                  Ipopt::Index* rows, Ipopt::Index* cols, Ipopt::Number* values) override {
    if (values == nullptr) {
      nlp_.jacobian_structure(rows, cols);
    } else {
      nlp_.jacobian_values(x, values);
    }
    return true;
  }
  bool eval_h(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number sigma, Ipopt::Index,
              const Ipopt::Number* lambda, bool, Ipopt::Index, Ipopt::Index* rows,
              Ipopt::Index* cols, Ipopt::Number* values) override {
    if (!exact_hessian_) return false;
    if (values == nullptr) {
      nlp_.hessian_structure(rows, cols);
    } else {
      nlp_.hessian_values(x, sigma, lambda, values);
    }
    return true;
  }
  // Ipopt calls this once an iteration (it runs in the calling thread): the solve's CPU limit.
  bool intermediate_callback(Ipopt::AlgorithmMode, Ipopt::Index, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    out_of_time_ = thread_cpu_time_s() > cpu_deadline_s_;
    return !out_of_time_;
  }
  void finalize_solution(Ipopt::SolverReturn status, Ipopt::Index n, const Ipopt::Number* x,
                         const Ipopt::Number* z_l, const Ipopt::Number* z_u, Ipopt::Index m,
                         const Ipopt::Number*, const Ipopt::Number* lambda, Ipopt::Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    status_ = status;
    x_.assign(x, x + n);
    final_.z_lower.assign(z_l, z_l + n);
    final_.z_upper.assign(z_u, z_u + n);
    final_.lambda.assign(lambda, lambda + m);
  }

 private:
  const TrajectoryNlp& nlp_;
  std::vector<double> x0_;
  std::vector<double> x_;
  Ipopt::SolverReturn status_ = Ipopt::INTERNAL_ERROR;
  bool exact_hessian_ = true;
  Multipliers warm_;
  Multipliers final_;
  double cpu_deadline_s_ = 0.0;
  bool out_of_time_ = false;
};

TrajectoryStatus status_of(Ipopt::SolverReturn s) {
  switch (s) {
    case Ipopt::SUCCESS:
    case Ipopt::STOP_AT_ACCEPTABLE_POINT:
      return TrajectoryStatus::kSolved;
    case Ipopt::LOCAL_INFEASIBILITY:
      return TrajectoryStatus::kInfeasible;
    case Ipopt::MAXITER_EXCEEDED:
      return TrajectoryStatus::kIterationLimit;
    case Ipopt::CPUTIME_EXCEEDED:
      return TrajectoryStatus::kTimeLimit;
    default:
      return TrajectoryStatus::kSolverError;
  }
}

}  // namespace

IpoptSolve solve_with_ipopt(const TrajectoryNlp& nlp, std::vector<double> x0,
                            const Multipliers& warm, const TrajectoryOptimizerOptions& options,
                            double max_cpu_time_s) {
  IpoptSolve out;
  out.x = x0;
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetIntegerValue("print_level", options.print_level);
  app->Options()->SetStringValue("sb", "yes");
  if (!options.exact_hessian) {
    app->Options()->SetStringValue("hessian_approximation", "limited-memory");
    app->Options()->SetIntegerValue("limited_memory_max_history", options.lbfgs_history);
  }
  app->Options()->SetStringValue("mu_strategy", options.adaptive_barrier ? "adaptive" : "monotone");
  app->Options()->SetStringValue("nlp_scaling_method", "user-scaling");
  // Our SparseLdlt (kkt_ldlt.hpp) in place of MUMPS; or MUMPS with the AMD ordering, which
  // on these banded KKT systems (a chain of waypoints per UAV, a few separation rows between
  // chains) factors faster than its automatic choice. No mandatory iterative-refinement step
  // (Ipopt still refines when the residual asks for it).
  std::optional<IpoptKktSolver> kkt_solver;
  if (options.kkt_factorization == KktFactorization::kSparseLdlt) {
    kkt_solver.emplace();
    for (const auto& [name, value] : IpoptKktSolver::ipopt_options())
      app->Options()->SetStringValue(name, value);
  } else {
    app->Options()->SetStringValue("linear_solver", "mumps");
    app->Options()->SetIntegerValue("mumps_pivot_order", 0);
  }
  app->Options()->SetIntegerValue("min_refinement_steps", 0);
  // Second-order corrections (Ipopt's default: up to 4 a step) made Ipopt cycle on these
  // problems: near a solution a rejected step's correction was accepted as a large jump away
  // from it, over and over until the iteration limit (options.second_order_corrections).
  if (!options.second_order_corrections) app->Options()->SetIntegerValue("max_soc", 0);
  app->Options()->SetNumericValue("tol", options.tolerance);
  app->Options()->SetNumericValue("constr_viol_tol", options.constraint_tolerance);
  app->Options()->SetIntegerValue("max_iter", options.max_iterations);
  // The CPU limit is the calling thread's (intermediate_callback), not Ipopt's max_cpu_time:
  // that one counts the whole process, so the other planning thread, or another plan running
  // in parallel (montecarlo), would spend this solve's time.
  const double cpu_deadline_s = max_cpu_time_s > 0.0
                                    ? thread_cpu_time_s() + max_cpu_time_s
                                    : std::numeric_limits<double>::infinity();
  if (!warm.empty()) {
    app->Options()->SetStringValue("warm_start_init_point", "yes");
    app->Options()->SetNumericValue("mu_init", options.warm_start_mu);
    app->Options()->SetNumericValue("warm_start_bound_push", 1e-6);
    app->Options()->SetNumericValue("warm_start_slack_bound_push", 1e-6);
    app->Options()->SetNumericValue("warm_start_mult_bound_push", 1e-6);
  }
  // No options file: an ipopt.opt in the working directory must not change a plan.
  if (app->Initialize(std::string()) != Ipopt::Solve_Succeeded) return out;
  Ipopt::SmartPtr<IpoptAdapter> adapter =
      new IpoptAdapter(nlp, std::move(x0), options.exact_hessian, warm, cpu_deadline_s);
  const auto t_solve = std::chrono::steady_clock::now();
  app->OptimizeTNLP(adapter);
  out.solve_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_solve).count();
  if (Ipopt::SmartPtr<Ipopt::SolveStatistics> stats = app->Statistics(); IsValid(stats))
    out.iterations = stats->IterationCount();
  out.status = adapter->out_of_time() ? TrajectoryStatus::kTimeLimit : status_of(adapter->status());
  out.x = adapter->x();
  out.multipliers = adapter->multipliers();
  return out;
}

}  // namespace ridgeline::planning::detail
