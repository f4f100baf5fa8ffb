#include "qp/ipopt_reference.hpp"

#include <coin/IpIpoptApplication.hpp>
#include <coin/IpSolveStatistics.hpp>
#include <coin/IpTNLP.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

namespace ridgeline::qp {
namespace {

class IpoptQp : public Ipopt::TNLP {
 public:
  explicit IpoptQp(const QpProblem& problem) : q_(problem) {}

  const Eigen::VectorXd& z() const { return z_; }
  double objective() const { return objective_; }

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac,
                    Ipopt::Index& nnz_h, IndexStyleEnum& style) override {
    n = num_variables();
    m = num_rows();
    nnz_jac = n * m;
    nnz_h = n * (n + 1) / 2;
    style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index m,
                       Ipopt::Number* g_l, Ipopt::Number* g_u) override {
    for (Ipopt::Index i = 0; i < n; ++i) {
      x_l[i] = q_.lb.size() != 0 ? clip(q_.lb[i]) : -kIpoptInfinity;
      x_u[i] = q_.ub.size() != 0 ? clip(q_.ub[i]) : kIpoptInfinity;
    }
    const Ipopt::Index mg = static_cast<Ipopt::Index>(q_.G.rows());
    for (Ipopt::Index j = 0; j < m; ++j) {
      if (j < mg) {
        g_l[j] = clip(q_.lg[j]);
        g_u[j] = clip(q_.ug[j]);
      } else {
        g_l[j] = g_u[j] = q_.b[j - mg];
      }
    }
    return true;
  }

  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool init_z,
                          Ipopt::Number*, Ipopt::Number*, Ipopt::Index, bool init_lambda,
                          Ipopt::Number*) override {
    if (!init_x || init_z || init_lambda) return false;
    std::fill(x, x + n, 0.0);
    return true;
  }

  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool, Ipopt::Number& obj) override {
    const Eigen::Map<const Eigen::VectorXd> z(x, n);
    obj = 0.5 * z.dot(q_.H * z) + q_.f.dot(z);
    return true;
  }

  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool,
                   Ipopt::Number* grad) override {
    const Eigen::Map<const Eigen::VectorXd> z(x, n);
    Eigen::Map<Eigen::VectorXd>(grad, n) = q_.H * z + q_.f;
    return true;
  }

  bool eval_g(Ipopt::Index n, const Ipopt::Number* x, bool, Ipopt::Index m,
              Ipopt::Number* g) override {
    const Eigen::Map<const Eigen::VectorXd> z(x, n);
    const Eigen::Index mg = q_.G.rows();
    Eigen::Map<Eigen::VectorXd> out(g, m);
    if (mg > 0) out.head(mg) = q_.G * z;
    if (q_.A.rows() > 0) out.tail(q_.A.rows()) = q_.A * z;
    return true;
  }

  bool eval_jac_g(Ipopt::Index n, const Ipopt::Number*, bool, Ipopt::Index m, Ipopt::Index,
                  Ipopt::Index* rows, Ipopt::Index* cols, Ipopt::Number* values) override {
    const Ipopt::Index mg = static_cast<Ipopt::Index>(q_.G.rows());
    Ipopt::Index k = 0;
    for (Ipopt::Index j = 0; j < m; ++j) {
      for (Ipopt::Index i = 0; i < n; ++i, ++k) {
        if (values == nullptr) {
          rows[k] = j;
          cols[k] = i;
        } else {
          values[k] = j < mg ? q_.G(j, i) : q_.A(j - mg, i);
        }
      }
    }
    return true;
  }

  bool eval_h(Ipopt::Index n, const Ipopt::Number*, bool, Ipopt::Number obj_factor,
              Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Index* rows,
              Ipopt::Index* cols, Ipopt::Number* values) override {
    Ipopt::Index k = 0;
    for (Ipopt::Index i = 0; i < n; ++i) {
      for (Ipopt::Index j = 0; j <= i; ++j, ++k) {
        if (values == nullptr) {
          rows[k] = i;
          cols[k] = j;
        } else {
          values[k] = obj_factor * q_.H(i, j);
        }
      }
    }
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index n, const Ipopt::Number* x,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Index,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number obj,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    z_ = Eigen::Map<const Eigen::VectorXd>(x, n);
    objective_ = obj;
  }

 private:
  // Ipopt's default nlp_lower/upper_bound_inf: beyond ±1e19 a side is absent.
  static constexpr double kIpoptInfinity = 1e19;
  static double clip(double v) { return std::clamp(v, -kIpoptInfinity, kIpoptInfinity); }

  Ipopt::Index num_variables() const { return static_cast<Ipopt::Index>(q_.H.rows()); }
  Ipopt::Index num_rows() const {
    return static_cast<Ipopt::Index>(q_.G.rows() + q_.A.rows());
  }

  const QpProblem& q_;
  Eigen::VectorXd z_;
  double objective_ = 0.0;
};

}  // namespace

IpoptQpSolution solve_with_ipopt(const QpProblem& problem, double tolerance,
                                 double bound_relax_factor) {
  Ipopt::SmartPtr<IpoptQp> nlp = new IpoptQp(problem);
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetNumericValue("tol", tolerance);
  app->Options()->SetStringValue("hessian_constant", "yes");
  app->Options()->SetStringValue("jac_c_constant", "yes");
  app->Options()->SetStringValue("jac_d_constant", "yes");
  app->Options()->SetStringValue("mu_strategy", "adaptive");
  app->Options()->SetIntegerValue("print_level", 0);
  app->Options()->SetStringValue("sb", "yes");  // no banner
  app->Options()->SetIntegerValue("max_iter", 3000);
  app->Options()->SetNumericValue("bound_relax_factor", bound_relax_factor);
  IpoptQpSolution out;
  if (app->Initialize(std::string()) != Ipopt::Solve_Succeeded) return out;
  const auto start = std::chrono::steady_clock::now();
  out.status = app->OptimizeTNLP(nlp);
  out.solve_time_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
  out.z = nlp->z();
  out.objective = nlp->objective();
  if (Ipopt::SmartPtr<Ipopt::SolveStatistics> stats = app->Statistics(); IsValid(stats)) {
    out.iterations = stats->IterationCount();
  }
  return out;
}

}  // namespace ridgeline::qp
