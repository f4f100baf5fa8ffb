#include "planning/target_allocation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "core/error.hpp"
#include "core/random.hpp"

namespace ridgeline::planning {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Relative tolerance for "this move improves J": below it a move is noise and would let the
// local search cycle between equal-cost solutions.
constexpr double kImprovementTolerance = 1e-12;

using Routes = std::vector<std::vector<int>>;

struct RouteValue {
  double cost = 0.0;           // C_i
  double priority_cost = 0.0;  // Σ π_j A_j over the route
};

// Evaluates routes under the objective J of the header.
class Evaluator {
 public:
  Evaluator(const AllocationProblem& problem, const AllocationOptions& options)
      : problem_(problem), options_(options) {
    int min_priority = std::numeric_limits<int>::max();
    for (const auto& t : problem.targets) min_priority = std::min(min_priority, t.priority);
    excess_priority_.reserve(problem.targets.size());
    for (const auto& t : problem.targets) {
      excess_priority_.push_back(static_cast<double>(t.priority) - min_priority);
    }
  }

  RouteValue route(int uav, const std::vector<int>& r) const {
    RouteValue v;
    for (std::size_t k = 0; k < r.size(); ++k) {
      // A target required of another UAV makes the route infeasible: J = ∞, never chosen (its
      // own UAV always offers a finite place).
      if (!allowed(uav, r[k])) return {kInf, kInf};
      v.cost += k == 0 ? problem_.start_cost(uav, r[0]) : problem_.target_cost(r[k - 1], r[k]);
      v.priority_cost += excess_priority_[r[k]] * v.cost;
    }
    if (problem_.end_cost.size() > 0)
      v.cost += r.empty() ? problem_.start_end_cost[static_cast<std::size_t>(uav)]
                          : problem_.end_cost(uav, r.back());
    return v;
  }

  bool allowed(int uav, int target) const {
    return problem_.required_uav.empty() || problem_.required_uav[target] < 0 ||
           problem_.required_uav[target] == uav;
  }
  /// The UAV target j must go to, or −1.
  int required_uav(int target) const {
    return problem_.required_uav.empty() ? -1 : problem_.required_uav[target];
  }

  double combine(const std::vector<RouteValue>& values) const {
    double max_cost = 0.0;
    double sum = 0.0;
    for (const auto& v : values) {
      max_cost = std::max(max_cost, v.cost);
      sum += v.cost + options_.priority_weight * v.priority_cost;
    }
    return options_.makespan_weight * max_cost + sum;
  }

  double excess_priority(int target) const { return excess_priority_[target]; }
  int priority(int target) const { return problem_.targets[target].priority; }

  // Positions q in [lo, hi] where target j may be inserted into r (before r[q]) keeping the
  // priorities non-increasing; r itself must be feasible.
  std::pair<int, int> insertion_range(const std::vector<int>& r, int j) const {
    const int p = priority(j);
    int lo = 0;
    while (lo < static_cast<int>(r.size()) && priority(r[lo]) > p) ++lo;
    int hi = lo;
    while (hi < static_cast<int>(r.size()) && priority(r[hi]) == p) ++hi;
    return {lo, hi};
  }

  bool feasible(const std::vector<int>& r) const {
    for (std::size_t k = 1; k < r.size(); ++k) {
      if (priority(r[k]) > priority(r[k - 1])) return false;
    }
    return true;
  }

 private:
  const AllocationProblem& problem_;
  const AllocationOptions& options_;
  std::vector<double> excess_priority_;
};

// The heuristic's working state: routes with cached per-route values.
struct Solution {
  Routes routes;
  std::vector<RouteValue> values;
  double objective = 0.0;
};

Solution make_solution(const Evaluator& eval, Routes routes) {
  Solution s;
  s.routes = std::move(routes);
  for (std::size_t i = 0; i < s.routes.size(); ++i) {
    s.values.push_back(eval.route(static_cast<int>(i), s.routes[i]));
  }
  s.objective = eval.combine(s.values);
  return s;
}

// J after replacing the routes listed in `changed` (uav index, new route value).
double objective_with(const Evaluator& eval, const Solution& s,
                      std::initializer_list<std::pair<int, RouteValue>> changed,
                      std::vector<RouteValue>& scratch) {
  scratch = s.values;
  for (const auto& [uav, value] : changed) scratch[uav] = value;
  return eval.combine(scratch);
}

enum class Construction { kRegret, kCheapest };

Solution construct(const Evaluator& eval, int n_uav, int n_target, Construction kind) {
  Solution s = make_solution(eval, Routes(n_uav));
  std::vector<bool> assigned(n_target, false);
  std::vector<RouteValue> scratch;
  for (int step = 0; step < n_target; ++step) {
    int best_target = -1, best_uav = -1, best_pos = -1;
    double best_key = -kInf, best_delta = kInf;
    for (int j = 0; j < n_target; ++j) {
      if (assigned[j]) continue;
      // Best and second-best insertion cost of j over the UAVs.
      double first = kInf, second = kInf;
      int first_uav = -1, first_pos = -1;
      for (int i = 0; i < n_uav; ++i) {
        const auto [lo, hi] = eval.insertion_range(s.routes[i], j);
        double uav_best = kInf;
        int uav_pos = -1;
        for (int q = lo; q <= hi; ++q) {
          std::vector<int> r = s.routes[i];
          r.insert(r.begin() + q, j);
          const double delta =
              objective_with(eval, s, {{i, eval.route(i, r)}}, scratch) - s.objective;
          if (delta < uav_best) {
            uav_best = delta;
            uav_pos = q;
          }
        }
        if (uav_best < first) {
          second = first;
          first = uav_best;
          first_uav = i;
          first_pos = uav_pos;
        } else if (uav_best < second) {
          second = uav_best;
        }
      }
      // Regret-2 inserts first the target that loses most if its best UAV is taken; with one UAV
      // (no second choice) it degenerates to cheapest insertion.
      const double key = kind == Construction::kRegret && n_uav > 1 ? second - first : -first;
      if (key > best_key || (key == best_key && first < best_delta)) {
        best_key = key;
        best_delta = first;
        best_target = j;
        best_uav = first_uav;
        best_pos = first_pos;
      }
    }
    auto& r = s.routes[best_uav];
    r.insert(r.begin() + best_pos, best_target);
    s.values[best_uav] = eval.route(best_uav, r);
    s.objective = eval.combine(s.values);
    assigned[best_target] = true;
  }
  return s;
}

// Best-improvement local search: relocate, swap, or-opt, 2-opt*, 2-opt. Returns the number of moves
// applied.
int local_search(const Evaluator& eval, Solution& s, int max_passes) {
  const int n_uav = static_cast<int>(s.routes.size());
  std::vector<RouteValue> scratch;
  int moves = 0;
  for (int pass = 0; pass < max_passes; ++pass) {
    const double threshold =
        s.objective - kImprovementTolerance * std::max(1.0, std::abs(s.objective));
    double best = threshold;
    Routes best_routes;
    std::vector<int> best_uavs;
    auto consider = [&](double value, int a, std::vector<int>&& ra, int b, std::vector<int>* rb) {
      if (value < best) {
        best = value;
        best_uavs = {a};
        best_routes = {std::move(ra)};
        if (rb != nullptr) {
          best_uavs.push_back(b);
          best_routes.push_back(*rb);
        }
      }
    };
    // Relocate one target to any priority-feasible position of any route (its own included).
    for (int a = 0; a < n_uav; ++a) {
      for (int p = 0; p < static_cast<int>(s.routes[a].size()); ++p) {
        const int j = s.routes[a][p];
        std::vector<int> removed = s.routes[a];
        removed.erase(removed.begin() + p);
        const RouteValue removed_value = eval.route(a, removed);
        for (int b = 0; b < n_uav; ++b) {
          const std::vector<int>& base = b == a ? removed : s.routes[b];
          const auto [lo, hi] = eval.insertion_range(base, j);
          for (int q = lo; q <= hi; ++q) {
            if (b == a && q == p) continue;
            std::vector<int> rb = base;
            rb.insert(rb.begin() + q, j);
            const RouteValue vb = eval.route(b, rb);
            if (b == a) {
              consider(objective_with(eval, s, {{a, vb}}, scratch), a, std::move(rb), -1, nullptr);
            } else {
              std::vector<int> ra = removed;
              consider(objective_with(eval, s, {{a, removed_value}, {b, vb}}, scratch), a,
                       std::move(ra), b, &rb);
            }
          }
        }
      }
    }
    // Swap two targets of different routes.
    for (int a = 0; a < n_uav; ++a) {
      for (int b = a + 1; b < n_uav; ++b) {
        for (std::size_t p = 0; p < s.routes[a].size(); ++p) {
          for (std::size_t q = 0; q < s.routes[b].size(); ++q) {
            std::vector<int> ra = s.routes[a], rb = s.routes[b];
            std::swap(ra[p], rb[q]);
            if (!eval.feasible(ra) || !eval.feasible(rb)) continue;
            const double value =
                objective_with(eval, s, {{a, eval.route(a, ra)}, {b, eval.route(b, rb)}}, scratch);
            consider(value, a, std::move(ra), b, &rb);
          }
        }
      }
    }
    // Or-opt: move a chain of 2 or 3 consecutive targets, order kept, to another place.
    for (int a = 0; a < n_uav; ++a) {
      const auto& r = s.routes[a];
      for (std::size_t len = 2; len <= 3; ++len) {
        for (std::size_t p = 0; p + len <= r.size(); ++p) {
          std::vector<int> chain(r.begin() + static_cast<long>(p),
                                 r.begin() + static_cast<long>(p + len));
          std::vector<int> removed = r;
          removed.erase(removed.begin() + static_cast<long>(p),
                        removed.begin() + static_cast<long>(p + len));
          const RouteValue removed_value = eval.route(a, removed);
          for (int b = 0; b < n_uav; ++b) {
            const std::vector<int>& base = b == a ? removed : s.routes[b];
            for (std::size_t q = 0; q <= base.size(); ++q) {
              if (b == a && q == p) continue;
              std::vector<int> rb = base;
              rb.insert(rb.begin() + static_cast<long>(q), chain.begin(), chain.end());
              if (!eval.feasible(rb)) continue;
              const RouteValue vb = eval.route(b, rb);
              if (b == a) {
                consider(objective_with(eval, s, {{a, vb}}, scratch), a, std::move(rb), -1,
                         nullptr);
              } else {
                std::vector<int> ra = removed;
                consider(objective_with(eval, s, {{a, removed_value}, {b, vb}}, scratch), a,
                         std::move(ra), b, &rb);
              }
            }
          }
        }
      }
    }
    // 2-opt*: exchange the tails of two routes (a[:p] + b[q:], b[:q] + a[p:]).
    for (int a = 0; a < n_uav; ++a) {
      for (int b = a + 1; b < n_uav; ++b) {
        const auto& ra0 = s.routes[a];
        const auto& rb0 = s.routes[b];
        for (std::size_t p = 0; p <= ra0.size(); ++p) {
          for (std::size_t q = 0; q <= rb0.size(); ++q) {
            if (p == ra0.size() && q == rb0.size()) continue;  // nothing exchanged
            std::vector<int> ra(ra0.begin(), ra0.begin() + static_cast<long>(p));
            ra.insert(ra.end(), rb0.begin() + static_cast<long>(q), rb0.end());
            std::vector<int> rb(rb0.begin(), rb0.begin() + static_cast<long>(q));
            rb.insert(rb.end(), ra0.begin() + static_cast<long>(p), ra0.end());
            if (!eval.feasible(ra) || !eval.feasible(rb)) continue;
            const double value =
                objective_with(eval, s, {{a, eval.route(a, ra)}, {b, eval.route(b, rb)}}, scratch);
            consider(value, a, std::move(ra), b, &rb);
          }
        }
      }
    }
    // 2-opt: reverse a segment of one route. Reversing keeps priorities non-increasing only when
    // the segment's priorities are all equal.
    for (int a = 0; a < n_uav; ++a) {
      const auto& r = s.routes[a];
      for (std::size_t p = 0; p + 2 < r.size() + 1; ++p) {
        for (std::size_t q = p + 2; q < r.size(); ++q) {
          if (eval.priority(r[p]) != eval.priority(r[q])) break;
          std::vector<int> ra = r;
          std::reverse(ra.begin() + static_cast<long>(p), ra.begin() + static_cast<long>(q) + 1);
          consider(objective_with(eval, s, {{a, eval.route(a, ra)}}, scratch), a, std::move(ra), -1,
                   nullptr);
        }
      }
    }
    if (best_uavs.empty()) break;
    for (std::size_t k = 0; k < best_uavs.size(); ++k) {
      s.routes[best_uavs[k]] = std::move(best_routes[k]);
      s.values[best_uavs[k]] = eval.route(best_uavs[k], s.routes[best_uavs[k]]);
    }
    s.objective = eval.combine(s.values);
    ++moves;
  }
  return moves;
}

std::string check_matrix(const MatX& m, const char* name, bool ignore_diagonal) {
  for (int r = 0; r < m.rows(); ++r) {
    for (int c = 0; c < m.cols(); ++c) {
      if (ignore_diagonal && r == c) continue;
      const double v = m(r, c);
      if (!std::isfinite(v))
        return fmt::format("{}({}, {}): cost is {}, must be finite", name, r, c, v);
      if (v < 0.0) return fmt::format("{}({}, {}): cost {} is negative", name, r, c, v);
    }
  }
  return {};
}

std::string validate(const AllocationProblem& problem, const AllocationOptions& options) {
  const auto n_uav = static_cast<Eigen::Index>(problem.uav_starts_m.size());
  const auto n_target = static_cast<Eigen::Index>(problem.targets.size());
  if (n_uav == 0) return "uav_starts_m: no UAVs to allocate targets to";
  if (n_target == 0) return "targets: no targets to allocate";
  if (!(options.makespan_weight >= 0.0) || !std::isfinite(options.makespan_weight)) {
    return fmt::format("options.makespan_weight: {} must be finite and >= 0",
                       options.makespan_weight);
  }
  if (!(options.priority_weight >= 0.0) || !std::isfinite(options.priority_weight)) {
    return fmt::format("options.priority_weight: {} must be finite and >= 0",
                       options.priority_weight);
  }
  if (problem.start_cost.rows() != n_uav || problem.start_cost.cols() != n_target) {
    return fmt::format("start_cost: size {}x{}, expected n_uav x n_target = {}x{}",
                       problem.start_cost.rows(), problem.start_cost.cols(), n_uav, n_target);
  }
  if (problem.target_cost.rows() != n_target || problem.target_cost.cols() != n_target) {
    return fmt::format("target_cost: size {}x{}, expected n_target x n_target = {}x{}",
                       problem.target_cost.rows(), problem.target_cost.cols(), n_target, n_target);
  }
  if (auto e = check_matrix(problem.start_cost, "start_cost", false); !e.empty()) return e;
  if (auto e = check_matrix(problem.target_cost, "target_cost", true); !e.empty()) return e;
  if (!problem.required_uav.empty()) {
    if (problem.required_uav.size() != static_cast<std::size_t>(n_target))
      return fmt::format("required_uav: {} entries, expected n_target = {}",
                         problem.required_uav.size(), n_target);
    for (std::size_t j = 0; j < problem.required_uav.size(); ++j)
      if (problem.required_uav[j] < -1 || problem.required_uav[j] >= n_uav)
        return fmt::format("required_uav[{}]: {} is neither -1 nor a UAV (0..{})", j,
                           problem.required_uav[j], n_uav - 1);
  }
  if (problem.end_cost.size() > 0 || !problem.start_end_cost.empty()) {
    if (problem.end_cost.rows() != n_uav || problem.end_cost.cols() != n_target ||
        problem.start_end_cost.size() != static_cast<std::size_t>(n_uav))
      return fmt::format(
          "end_cost: size {}x{} and start_end_cost: {} entries, expected {}x{} "
          "and {}",
          problem.end_cost.rows(), problem.end_cost.cols(), problem.start_end_cost.size(), n_uav,
          n_target, n_uav);
    if (auto e = check_matrix(problem.end_cost, "end_cost", false); !e.empty()) return e;
    for (std::size_t i = 0; i < problem.start_end_cost.size(); ++i)
      if (!(problem.start_end_cost[i] >= 0.0) || !std::isfinite(problem.start_end_cost[i]))
        return fmt::format("start_end_cost[{}]: cost is {}, must be finite and >= 0", i,
                           problem.start_end_cost[i]);
  }
  return {};
}

// n_u ≥ n_t, one target per UAV: exact minimum of λ·max S + Σ (1 + β π_j) S over injective maps
// targets → UAVs. Rows are targets, columns UAVs.
Routes solve_one_per_uav(const AllocationProblem& problem, const AllocationOptions& options,
                         const Evaluator& eval, int& solves) {
  const int n_uav = static_cast<int>(problem.uav_starts_m.size());
  const int n_target = static_cast<int>(problem.targets.size());
  MatX raw(n_target, n_uav), weighted(n_target, n_uav);
  for (int j = 0; j < n_target; ++j) {
    for (int i = 0; i < n_uav; ++i) {
      raw(j, i) = problem.start_cost(i, j);
      weighted(j, i) = (1.0 + options.priority_weight * eval.excess_priority(j)) * raw(j, i);
    }
  }
  auto value_of = [&](const std::vector<int>& target_to_uav) {
    double max_cost = 0.0, sum = 0.0;
    for (int j = 0; j < n_target; ++j) {
      max_cost = std::max(max_cost, raw(j, target_to_uav[j]));
      sum += weighted(j, target_to_uav[j]);
    }
    return options.makespan_weight * max_cost + sum;
  };
  Assignment best = solve_assignment(weighted);
  ++solves;
  double best_value = value_of(best.row_to_col);
  if (options.makespan_weight > 0.0) {
    // The optimum has some makespan τ* among the entries; with entries > τ* forbidden, the
    // min-sum assignment is at least as good as the optimum. Sweep τ upwards; an assignment
    // found at τ is worth at least λτ + (unconstrained min sum) if its makespan is τ (a smaller
    // makespan was already seen at a smaller τ), so the sweep stops once that bound fails.
    const double min_sum = best.total_cost;
    std::vector<double> thresholds(raw.data(), raw.data() + raw.size());
    std::sort(thresholds.begin(), thresholds.end());
    thresholds.erase(std::unique(thresholds.begin(), thresholds.end()), thresholds.end());
    MatX masked(n_target, n_uav);
    for (double tau : thresholds) {
      if (options.makespan_weight * tau + min_sum >= best_value) break;
      for (int j = 0; j < n_target; ++j) {
        for (int i = 0; i < n_uav; ++i) masked(j, i) = raw(j, i) <= tau ? weighted(j, i) : kInf;
      }
      Assignment a = solve_assignment(masked);
      ++solves;
      if (!a.feasible) continue;
      const double v = value_of(a.row_to_col);
      if (v < best_value) {
        best_value = v;
        best = std::move(a);
      }
    }
  }
  Routes routes(n_uav);
  for (int j = 0; j < n_target; ++j) routes[best.row_to_col[j]].push_back(j);
  return routes;
}

}  // namespace

std::string_view to_string(AllocationStatus status) {
  switch (status) {
    case AllocationStatus::kOptimal:
      return "optimal";
    case AllocationStatus::kHeuristic:
      return "heuristic";
    case AllocationStatus::kInvalidInput:
      return "invalid input";
  }
  return "unknown";
}

Assignment solve_assignment(const MatX& cost) {
  const int n = static_cast<int>(cost.rows());
  const int m = static_cast<int>(cost.cols());
  if (n > m) throw std::invalid_argument("solve_assignment: more rows than columns");
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < m; ++c) {
      if (std::isnan(cost(r, c)) || cost(r, c) == -kInf) {
        throw std::invalid_argument(
            fmt::format("solve_assignment: cost({}, {}) is {}", r, c, cost(r, c)));
      }
    }
  }
  Assignment result;
  result.row_to_col.assign(n, -1);
  if (n == 0) {
    result.feasible = true;
    return result;
  }
  // Shortest augmenting paths with dual potentials u (rows), v (columns): reduced costs
  // c(i, j) − u_i − v_j stay ≥ 0 and are 0 on the matching. Row i is added by a Dijkstra-like
  // search over columns (index 0 is a virtual column holding the new row); each of the n
  // phases costs O(n·m). Indices are 1-based inside, as the virtual column is 0.
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0), min_reduced(m + 1);
  std::vector<int> row_of_col(m + 1, 0), previous_col(m + 1, 0);
  std::vector<char> visited(m + 1);
  for (int i = 1; i <= n; ++i) {
    row_of_col[0] = i;
    int col = 0;
    std::fill(min_reduced.begin(), min_reduced.end(), kInf);
    std::fill(visited.begin(), visited.end(), 0);
    do {
      visited[col] = 1;
      const int row = row_of_col[col];
      double delta = kInf;
      int next_col = -1;
      for (int j = 1; j <= m; ++j) {
        if (visited[j]) continue;
        const double reduced = cost(row - 1, j - 1) - u[row] - v[j];
        if (reduced < min_reduced[j]) {
          min_reduced[j] = reduced;
          previous_col[j] = col;
        }
        if (min_reduced[j] < delta) {
          delta = min_reduced[j];
          next_col = j;
        }
      }
      if (next_col < 0 || delta == kInf) return result;  // only forbidden pairs remain
      for (int j = 0; j <= m; ++j) {
        if (visited[j]) {
          u[row_of_col[j]] += delta;
          v[j] -= delta;
        } else {
          min_reduced[j] -= delta;
        }
      }
      col = next_col;
    } while (row_of_col[col] != 0);
    // Augment along the alternating path back to the virtual column.
    do {
      const int prev = previous_col[col];
      row_of_col[col] = row_of_col[prev];
      col = prev;
    } while (col != 0);
  }
  for (int j = 1; j <= m; ++j) {
    if (row_of_col[j] != 0) result.row_to_col[row_of_col[j] - 1] = j - 1;
  }
  for (int r = 0; r < n; ++r) result.total_cost += cost(r, result.row_to_col[r]);
  result.feasible = true;
  return result;
}

double allocation_objective(const AllocationProblem& problem,
                            const std::vector<std::vector<int>>& routes,
                            const AllocationOptions& options) {
  const Evaluator eval(problem, options);
  std::vector<RouteValue> values;
  for (std::size_t i = 0; i < routes.size(); ++i)
    values.push_back(eval.route(static_cast<int>(i), routes[i]));
  return eval.combine(values);
}

bool routes_respect_priority(const AllocationProblem& problem,
                             const std::vector<std::vector<int>>& routes) {
  for (const auto& r : routes) {
    for (std::size_t k = 1; k < r.size(); ++k) {
      if (problem.targets[r[k]].priority > problem.targets[r[k - 1]].priority) return false;
    }
  }
  return true;
}

AllocationResult allocate_targets(const AllocationProblem& problem,
                                  const AllocationOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  AllocationResult result;
  if (std::string error = validate(problem, options); !error.empty()) {
    result.status = AllocationStatus::kInvalidInput;
    result.message = std::move(error);
    return result;
  }
  const int n_uav = static_cast<int>(problem.uav_starts_m.size());
  const int n_target = static_cast<int>(problem.targets.size());
  const Evaluator eval(problem, options);

  const bool free_targets = std::all_of(problem.required_uav.begin(), problem.required_uav.end(),
                                        [](int uav) { return uav < 0; });
  if (n_uav >= n_target && free_targets && problem.end_cost.size() == 0) {
    result.routes = solve_one_per_uav(problem, options, eval, result.hungarian_solves);
    result.status = AllocationStatus::kOptimal;
  } else {
    Solution best;
    bool have = false;
    for (Construction kind : {Construction::kRegret, Construction::kCheapest}) {
      Solution s = construct(eval, n_uav, n_target, kind);
      result.local_search_moves += local_search(eval, s, options.max_local_search_passes);
      if (!have || s.objective < best.objective) {
        best = std::move(s);
        have = true;
      }
    }
    // Iterated local search: kick the incumbent (two targets moved to random priority-feasible
    // places), descend again, keep the result only if it is better. Seeded, so deterministic.
    Rng rng(options.perturbation_seed);
    for (int round = 0; round < options.perturbation_rounds; ++round) {
      Solution s = best;
      for (int kick = 0; kick < 2; ++kick) {
        const int j = std::min(n_target - 1, static_cast<int>(rng.uniform() * n_target));
        for (auto& r : s.routes) r.erase(std::remove(r.begin(), r.end(), j), r.end());
        int i = std::min(n_uav - 1, static_cast<int>(rng.uniform() * n_uav));
        if (eval.required_uav(j) >= 0) i = eval.required_uav(j);  // a required target stays
        const auto [lo, hi] = eval.insertion_range(s.routes[i], j);
        const int q = std::min(hi, lo + static_cast<int>(rng.uniform() * (hi - lo + 1)));
        s.routes[i].insert(s.routes[i].begin() + q, j);
      }
      s = make_solution(eval, std::move(s.routes));
      result.local_search_moves += local_search(eval, s, options.max_local_search_passes);
      if (s.objective < best.objective) best = std::move(s);
    }
    result.routes = std::move(best.routes);
    result.status = AllocationStatus::kHeuristic;
  }

  result.uav_of_target.assign(n_target, -1);
  result.route_cost.assign(n_uav, 0.0);
  for (int i = 0; i < n_uav; ++i) {
    for (int j : result.routes[i]) result.uav_of_target[j] = i;
    const RouteValue v = eval.route(i, result.routes[i]);
    result.route_cost[i] = v.cost;
    result.makespan = std::max(result.makespan, v.cost);
    result.total_cost += v.cost;
    result.priority_cost += v.priority_cost;
  }
  result.objective = options.makespan_weight * result.makespan + result.total_cost +
                     options.priority_weight * result.priority_cost;
  result.solve_time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

double estimate_leg_cost(const world::Terrain& terrain, const Vec3& a_m, const Vec3& b_m,
                         const world::SafetyLimits& limits, const CostEstimateOptions& options) {
  const double horizontal = (b_m - a_m).head<2>().norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(horizontal / options.sample_step_m)));
  const double floor_offset = limits.clearance_floor_m(terrain);
  auto flown = [&](double t) {
    const Vec3 p = a_m + t * (b_m - a_m);
    // The endpoints are where they are; only the interior is lifted over the terrain.
    if (t <= 0.0 || t >= 1.0) return p.z();
    return std::max(p.z(), terrain.height(p.x(), p.y()) + floor_offset);
  };
  double cost = 0.0;
  double z_prev = flown(0.0);
  const double ds = horizontal / steps;
  for (int k = 1; k <= steps; ++k) {
    const double z = flown(static_cast<double>(k) / steps);
    const double dz = z - z_prev;
    cost += std::sqrt(ds * ds + dz * dz) + options.climb_penalty * std::max(0.0, dz);
    z_prev = z;
  }
  return cost;
}

AllocationCosts estimate_allocation_costs(const world::Terrain& terrain,
                                          const std::vector<Vec3>& uav_starts_m,
                                          const std::vector<AllocationTarget>& targets,
                                          const world::SafetyLimits& limits,
                                          const CostEstimateOptions& options,
                                          const std::vector<std::optional<Vec3>>& uav_ends_m) {
  world::validate(limits);
  if (!(options.sample_step_m > 0.0) || !std::isfinite(options.sample_step_m)) {
    throw InputError("cost_estimate.sample_step_m",
                     fmt::format("{} must be finite and > 0", options.sample_step_m));
  }
  if (!(options.climb_penalty >= 0.0) || !std::isfinite(options.climb_penalty)) {
    throw InputError("cost_estimate.climb_penalty",
                     fmt::format("{} must be finite and >= 0", options.climb_penalty));
  }
  const auto n_uav = static_cast<Eigen::Index>(uav_starts_m.size());
  const auto n_target = static_cast<Eigen::Index>(targets.size());
  AllocationCosts costs;
  costs.start_cost.resize(n_uav, n_target);
  costs.target_cost = MatX::Zero(n_target, n_target);
  for (Eigen::Index i = 0; i < n_uav; ++i) {
    for (Eigen::Index j = 0; j < n_target; ++j) {
      costs.start_cost(i, j) =
          estimate_leg_cost(terrain, uav_starts_m[i], targets[j].position_m, limits, options);
    }
  }
  for (Eigen::Index j = 0; j < n_target; ++j) {
    for (Eigen::Index k = 0; k < n_target; ++k) {
      if (j != k)
        costs.target_cost(j, k) = estimate_leg_cost(terrain, targets[j].position_m,
                                                    targets[k].position_m, limits, options);
    }
  }
  if (std::any_of(uav_ends_m.begin(), uav_ends_m.end(),
                  [](const auto& e) { return e.has_value(); })) {
    if (uav_ends_m.size() != uav_starts_m.size())
      throw InputError("uav_ends_m",
                       fmt::format("{} ends for {} UAVs", uav_ends_m.size(), uav_starts_m.size()));
    costs.end_cost = MatX::Zero(n_uav, n_target);
    costs.start_end_cost.assign(static_cast<std::size_t>(n_uav), 0.0);
    for (Eigen::Index i = 0; i < n_uav; ++i) {
      const auto& end = uav_ends_m[static_cast<std::size_t>(i)];
      if (!end) continue;
      costs.start_end_cost[static_cast<std::size_t>(i)] =
          estimate_leg_cost(terrain, uav_starts_m[i], *end, limits, options);
      for (Eigen::Index j = 0; j < n_target; ++j)
        costs.end_cost(i, j) =
            estimate_leg_cost(terrain, targets[j].position_m, *end, limits, options);
    }
  }
  return costs;
}

}  // namespace ridgeline::planning
