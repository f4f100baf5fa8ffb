#include "planning/priority_decomposition.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <optional>
#include <set>
#include <thread>

#include "planning/trajectory_ipopt.hpp"

namespace ridgeline::planning::detail {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// A UAV's final solution: its waypoints on the grid and the reference it flies.
struct Solved {
  std::vector<Vec3> waypoints;
  TimeParametrizationResult timing;
  TimedPath flown;  // the reference's samples
  UavCost cost;
  UavCost initial_cost;
  double objective = 0.0;
  double initial_objective = 0.0;
  int iterations = 0;
  int solves = 0;
  bool feasible_stop = false;  // the last solve stopped at the iteration limit, feasible
  int variables = 0;
  int constraints = 0;
  int obstacle_rows = 0;
  double solve_time_s = 0.0;
};

struct Outcome {
  TrajectoryStatus status = TrajectoryStatus::kSolved;
  std::string message;
  std::optional<Solved> solved;
  /// A failure against a fixed UAV: the one whose rows were violated most (Ipopt's stop) or
  /// that the last solve came closest to (the dense check); −1 when no other UAV was involved.
  int blocker = -1;
};

// p(t) of a piecewise-linear timed path, holding before and after it; `hint` is the segment of
// the last query (queries at increasing times cost O(1) each).
Vec3 position_at(const TimedPath& path, double t, std::size_t& hint) {
  const auto& times = path.times_s;
  if (t <= times.front()) return path.waypoints_m.front();
  if (t >= times.back()) return path.waypoints_m.back();
  if (hint >= times.size() - 1 || times[hint] > t) hint = 0;
  while (times[hint + 1] < t) ++hint;
  const double s = (t - times[hint]) / (times[hint + 1] - times[hint]);
  return path.waypoints_m[hint] + s * (path.waypoints_m[hint + 1] - path.waypoints_m[hint]);
}

Vec3 held(const std::vector<Vec3>& w, int k) { return w[std::min<std::size_t>(k, w.size() - 1)]; }

// The fastest any UAV flies: how far two UAVs can close on each other between grid times.
double max_speed(const TrajectoryProblem& problem) {
  double v = 0.0;
  for (const TrajectoryUav& u : problem.uavs) v = std::max(v, u.vehicle.max_speed_m_s());
  return v;
}

// One separation violation of a UAV's reference against another's, the worst of its grid step.
struct SeparationHit {
  int other = 0;
  int step = 0;
  double time_s = 0.0;
  double distance_m = 0.0;
  Vec3 position_m = Vec3::Zero();
};

class UavSolver {
 public:
  /// UAV `uav` of the team, from its grid guess or `grid` when given.
  UavSolver(const TrajectoryProblem& problem, const TrajectoryOptimizerOptions& options,
            const TeamGrid& team, int uav, const GridUav* grid = nullptr)
      : problem_(problem), options_(options), team_(team), uav_(uav) {
    single_.terrain = problem.terrain;
    single_.optimization_terrain = problem.optimization_terrain;
    single_.limits = problem.limits;
    single_.uavs = {problem.uavs[static_cast<std::size_t>(uav)]};
    own_.uavs = {grid != nullptr ? *grid : team.uavs[static_cast<std::size_t>(uav)]};
    own_.dt = team.dt;
    own_.max_index = own_.uavs[0].segments();
    // Grid steps on which two UAVs at most `reach_` apart at both ends can come within the
    // prefilter (or d_safe) between them, their references' corners included.
    reach_ = std::max(options.separation_prefilter_m, options.obstacle_prefilter_m) +
             2.0 * max_speed(problem) * team.dt + 30.0;
  }

  /// Solves against `others` (indices into the team with their solutions) within the budget
  /// of `meter` (this thread's), from `start` (waypoints on the grid) or else the UAV's guess.
  Outcome solve(const std::vector<std::pair<int, const Solved*>>& others, CpuMeter& meter,
                const std::vector<Vec3>* start = nullptr) {
    const GridUav& g = own_.uavs[0];
    const int n = g.segments();
    NlpSetup setup;
    setup.terrain = problem_.optimization_terrain != nullptr ? problem_.optimization_terrain
                                                              : problem_.terrain;
    setup.uavs = own_.uavs;
    setup.time_step_s = team_.dt;
    setup.limits = problem_.limits;
    setup.options = options_;
    // The sharpest corner the timing can round within a step at the slowest speed: an arc of
    // k_s·R_min may use half of each neighbouring segment, tan(φ/2) ≤ (v0 − Δv)·Δt / (2·k_s·R_min).
    // Short steps (many waypoints) and slow climbs otherwise leave corners of φ_max = 60° that
    // no arc fits; the turn penalty starts there instead.
    const vehicle::VehicleParams& vehicle = single_.uavs.front().vehicle;
    const double arc_m = options_.timing.turn_radius_safety_factor * vehicle.min_turn_radius_m;
    if (arc_m > 0.0)
      setup.options.max_turn_angle_rad =
          std::min(options_.max_turn_angle_rad,
                   2.0 * std::atan(vehicle.min_speed_m_s() * team_.dt / (2.0 * arc_m)));
    setup.terrain_samples.emplace_back(n, options_.terrain_samples_per_segment);
    setup.clearance_extra_m.emplace_back(g.guess_m.size(), 0.0);
    PlanValidationOptions validation;
    validation.terrain_step_m = options_.validation_terrain_step_m;
    validation.separation_period_s = options_.validation_separation_period_s;

    Solved out;
    Candidates unused;
    std::vector<Vec3> current = start != nullptr ? *start : g.guess_m;
    std::map<TrajectoryNlp::RowKey, double> previous_lambda;
    Multipliers previous_bounds;
    bool have_previous = false;
    std::string last_problem;
    for (int round = 0; round <= options_.uav_max_refinements; ++round) {
      setup.obstacles = obstacle_rows(others, current);
      const TrajectoryNlp nlp(setup);
      out.variables = nlp.num_variables();
      out.constraints = nlp.num_constraints();
      out.obstacle_rows = nlp.obstacle_rows();
      std::vector<double> x0(nlp.num_variables());
      Multipliers warm;
      if (!have_previous) {
        nlp.initial_point(x0.data());
        out.initial_cost = nlp.costs(x0.data(), nullptr).front();
        out.initial_objective = nlp.objective(x0.data());
        if (start != nullptr) nlp.pack({current}, x0.data());
      } else {
        nlp.pack({current}, x0.data());
        if (options_.warm_start_refinements)
          warm = detail::warm_start(nlp, previous_bounds, previous_lambda);
      }
      const double remaining_s = meter.remaining_s();
      if (remaining_s <= 0.0)
        return {TrajectoryStatus::kTimeLimit,
                fmt::format("{}: time budget of {:.1f} s CPU exhausted after {} solve(s)", g.name,
                            options_.time_budget_s, out.solves),
                {}};
      TrajectoryOptimizerOptions solve_options = options_;
      // One UAV's NLP: iterations_per_uav (Ipopt needs 5–150 on the generated teams; a stall at a
      // feasible point is taken below).
      solve_options.max_iterations = std::max(1, options_.iterations_per_uav);
      const IpoptSolve solve = solve_with_ipopt(nlp, std::move(x0), warm, solve_options, remaining_s);
      out.solve_time_s += solve.solve_time_s;
      ++out.solves;
      out.iterations += solve.iterations;
      // At Ipopt's iteration limit the last iterate goes on to the dense check like a solution:
      // if it passes, it is a validated plan, not a proved optimum (counted as such); if not,
      // the check refines the rows and the next solve starts from it.
      const bool feasible_stop = solve.status == TrajectoryStatus::kIterationLimit;
      if (solve.status != TrajectoryStatus::kSolved && !feasible_stop) {
        const std::string where = nlp.worst_rows(solve.x.data(), 3);
        return {solve.status,
                fmt::format("{}: Ipopt stopped ({}) in solve {}: {}", g.name,
                            to_string(solve.status), out.solves,
                            where.empty() ? "no violated row" : where),
                {},
                most_violated(setup.obstacles, nlp.unpack(solve.x.data()).front())};
      }
      const std::vector<Vec3> waypoints = nlp.unpack(solve.x.data()).front();
      const std::vector<TimedPath> paths = timed_paths(own_.uavs, {waypoints}, team_.dt);
      PlanValidationReport own_check = validate_plan(*problem_.terrain, paths, problem_.limits, validation);
      FlownCheck flown = check_flown(single_, paths, options_, own_, validation);
      TimedPath reference = paths.front();
      if (!flown.timing.front().samples.empty()) {
        reference.times_s = flown.timing.front().sample_times_s;
        reference.waypoints_m.clear();
        for (const auto& s : flown.timing.front().samples) reference.waypoints_m.push_back(s.position_m);
      }
      const std::vector<SeparationHit> hits = separation_hits(reference, waypoints, others);
      // A corner the timing cannot round within R_min (or the lateral acceleration), typically
      // a sharp dodge on short segments: this UAV's turn penalty starts at a smaller φ_max, and
      // The two segments at that corner are held to at least cruise length (the speed band's
      // lower bound), which gives the arc room.
      std::string sharp;
      for (const LimitViolation& v : flown.timing.front().violations) {
        if (v.kind != LimitKind::kTurnRadius && v.kind != LimitKind::kLateralAccel) continue;
        sharp = v.description;
        GridUav& u = setup.uavs.front();
        for (int k : {v.waypoint - 1, v.waypoint})
          if (k >= 0 && k < n) u.min_length_m[k] = std::max(u.min_length_m[k], u.nominal_length_m);
      }
      if (!sharp.empty()) setup.options.max_turn_angle_rad *= 0.75;
      if (own_check.passed() && flown.validation.passed() && flown.steep.empty() && hits.empty() &&
          sharp.empty()) {
        out.waypoints = waypoints;
        out.timing = std::move(flown.timing.front());
        out.flown = std::move(reference);
        out.cost = nlp.costs(solve.x.data(), nullptr).front();
        out.objective = nlp.objective(solve.x.data());
        out.feasible_stop = feasible_stop;
        return {round == 0 ? TrajectoryStatus::kSolved : TrajectoryStatus::kSolvedAfterRefinement,
                "", std::move(out)};
      }
      refine_where_broken(own_check, own_, options_, setup, unused);
      refine_where_broken(flown.validation, own_, options_, setup, unused);
      bound_grades(flown.steep, setup);
      // The reference's rounded corners move it off the waypoints' chords by metres: each miss
      // adds itself plus 0.3 m to the margin of the step and its neighbours, and doubles their
      // samples (the joint optimizer's + 0.1 m took every round on 100 UAVs).
      for (const SeparationHit& hit : hits)
        for (int kk = hit.step - 1; kk <= hit.step + 1; ++kk) {
          if (kk < 0 || kk >= n) continue;
          auto [it, inserted] = refinement_.try_emplace({hit.other, kk},
                                                        options_.separation_samples_per_step, 0.0);
          it->second.first = 2 * it->second.first + 1;
          it->second.second += problem_.limits.separation_m - hit.distance_m + 0.3;
        }
      if (!hits.empty()) {
        const SeparationHit& h = hits.front();
        last_problem = fmt::format(
            "separation (eq. 21): {} and {} are {:.2f} m apart at t = {:.2f} s near ({:.1f}, "
            "{:.1f}, {:.1f}), below d_safe {} m",
            g.name, problem_.uavs[static_cast<std::size_t>(h.other)].name, h.distance_m, h.time_s,
            h.position_m.x(), h.position_m.y(), h.position_m.z(), problem_.limits.separation_m);
      } else if (!sharp.empty()) {
        last_problem = "turn: " + g.name + ": " + sharp;
      } else if (!flown.steep.empty()) {
        last_problem = "grade: " + flown.steep.front().description;
      } else {
        last_problem = !own_check.passed() ? own_check.summary(1) : flown.validation.summary(1);
      }
      if (!hits.empty())
        blocker_ = std::min_element(hits.begin(), hits.end(), [](const auto& a, const auto& b) {
                     return a.distance_m < b.distance_m;
                   })->other;
      current = waypoints;
      have_previous = true;
      previous_bounds = solve.multipliers;
      previous_lambda.clear();
      for (int r = 0; r < nlp.num_constraints(); ++r)
        previous_lambda[nlp.row_key(r)] = previous_bounds.lambda[static_cast<std::size_t>(r)];
    }
    return {TrajectoryStatus::kValidationFailed,
            fmt::format("{}: every one of {} solve(s) broke a hard constraint in the dense check; "
                        "last: {}",
                        g.name, out.solves, last_problem),
            {},
            blocker_};
  }

 private:
  // The other UAV of the obstacle row that `points` miss by the most, or −1 when none misses.
  static int most_violated(const std::vector<ObstacleRow>& rows, const std::vector<Vec3>& points) {
    int worst = -1;
    double miss = 0.0;
    for (const ObstacleRow& r : rows) {
      const std::size_t k = static_cast<std::size_t>(r.k);
      const Vec3 q = r.tau > 0.0 ? Vec3((1.0 - r.tau) * points[k] + r.tau * points[k + 1]) : points[k];
      const Vec3 ab = r.b_m - r.a_m;
      const double s = ab.squaredNorm() > 0.0 ? std::clamp((q - r.a_m).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
      const double m = r.min_distance_m - (q - (r.a_m + s * ab)).norm();
      if (m > miss) {
        miss = m;
        worst = r.source;
      }
    }
    return worst;
  }

  // Obstacle rows where `points` come within the prefilter of another UAV's reference.
  std::vector<ObstacleRow> obstacle_rows(const std::vector<std::pair<int, const Solved*>>& others,
                                         const std::vector<Vec3>& points) {
    const GridUav& g = own_.uavs[0];
    const double dt = team_.dt;
    const double d_min = problem_.limits.separation_m + options_.separation_margin_m;
    std::vector<ObstacleRow> rows;
    for (const auto& [index, other] : others) {
      std::size_t hint = 0;
      for (int k = 0; k < g.segments(); ++k) {
        const double near = std::min((points[k] - held(other->waypoints, k)).norm(),
                                     (points[k + 1] - held(other->waypoints, k + 1)).norm());
        const bool kept = with_rows_.count({index, k}) != 0;
        if (near > reach_ && !kept) continue;
        int samples = options_.separation_samples_per_step;
        double extra = 0.0;
        if (auto it = refinement_.find({index, k}); it != refinement_.end())
          std::tie(samples, extra) = it->second;
        std::vector<ObstacleRow> step_rows;
        bool near_step = kept;
        for (int m = 0; m <= samples; ++m) {
          const double tau = static_cast<double>(m) / (samples + 1);
          if (m == 0 && g.fixed[k]) continue;
          const Vec3 q = (1.0 - tau) * points[k] + tau * points[k + 1];
          const Vec3 c = position_at(other->flown, (k + tau) * dt, hint);
          near_step = near_step || (q - c).norm() <= options_.obstacle_prefilter_m;
          step_rows.push_back({0, k, tau, c, c, d_min + extra, false, index});
        }
        if (!near_step) continue;
        with_rows_.insert({index, k});
        rows.insert(rows.end(), step_rows.begin(), step_rows.end());
      }
    }
    return rows;
  }

  // The reference against each other's at every sample (and the others' samples after it ends,
  // holding at its last point), on the grid steps where they can meet.
  std::vector<SeparationHit> separation_hits(
      const TimedPath& reference, const std::vector<Vec3>& waypoints,
      const std::vector<std::pair<int, const Solved*>>& others) const {
    const double d_safe = problem_.limits.separation_m;
    const double dt = team_.dt;
    std::vector<SeparationHit> hits;
    for (const auto& [index, other] : others) {
      std::map<int, SeparationHit> worst;  // by step
      auto check = [&](double t, const Vec3& p, const Vec3& q) {
        const double d = (p - q).norm();
        if (d >= d_safe - 1e-6) return;
        const int step = static_cast<int>(std::floor(t / dt));
        auto [it, inserted] = worst.try_emplace(step, SeparationHit{index, step, t, d, p});
        if (!inserted && d < it->second.distance_m) it->second = {index, step, t, d, p};
      };
      auto near_step = [&](double t) {
        const int k = static_cast<int>(std::floor(t / dt));
        return std::min((held(waypoints, k) - held(other->waypoints, k)).norm(),
                        (held(waypoints, k + 1) - held(other->waypoints, k + 1)).norm()) <= reach_;
      };
      std::size_t hint = 0;
      for (std::size_t m = 0; m < reference.times_s.size(); ++m) {
        const double t = reference.times_s[m];
        if (near_step(t)) check(t, reference.waypoints_m[m], position_at(other->flown, t, hint));
      }
      const double end = reference.times_s.back();
      for (std::size_t m = 0; m < other->flown.times_s.size(); ++m) {
        const double t = other->flown.times_s[m];
        if (t > end && near_step(t)) check(t, reference.waypoints_m.back(), other->flown.waypoints_m[m]);
      }
      for (auto& [step, hit] : worst) hits.push_back(hit);
    }
    return hits;
  }

  const TrajectoryProblem& problem_;
  const TrajectoryOptimizerOptions& options_;
  const TeamGrid& team_;
  int uav_ = 0;
  TrajectoryProblem single_;
  TeamGrid own_;
  double reach_ = 0.0;
  std::map<std::pair<int, int>, std::pair<int, double>> refinement_;  // (other, step) → samples, extra
  std::set<std::pair<int, int>> with_rows_;  // (other, step) that had obstacle rows: kept
  int blocker_ = -1;  // the nearest other UAV of the last dense check that failed on separation
};

// Earlier UAVs (in `order`) whose guesses come within `distance_m` of each UAV's at equal times.
std::vector<std::vector<int>> couplings(const TeamGrid& team, const std::vector<int>& order,
                                        double distance_m) {
  const int n = static_cast<int>(team.uavs.size());
  std::vector<std::vector<int>> deps(n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < a; ++b) {
      const int i = order[a], j = order[b];
      const std::vector<Vec3>& gi = team.uavs[i].guess_m;
      const std::vector<Vec3>& gj = team.uavs[j].guess_m;
      for (int k = 0; k <= team.max_index; ++k)
        if ((held(gi, k) - held(gj, k)).norm() < distance_m) {
          deps[i].push_back(j);
          break;
        }
    }
  return deps;
}

// UAV i's guess lifted (and if need be delayed) away from the fixed solutions of `others` at
// twice d_safe (guess_deconfliction.hpp, with the others' points all fixed): its second start
// when the first failed, typically a guess running through a fixed UAV where terrain and climb
// limits leave Ipopt no way round from there.
GridUav guess_around(const TrajectoryProblem& problem, const TrajectoryOptimizerOptions& options,
                     const TeamGrid& team, int i,
                     const std::vector<std::pair<int, const Solved*>>& others) {
  TrajectoryProblem sub;
  sub.terrain = problem.terrain;
  sub.limits = problem.limits;
  TeamGrid grid;
  grid.dt = team.dt;
  for (const auto& [j, solved] : others) {
    GridUav g = team.uavs[static_cast<std::size_t>(j)];
    g.guess_m = solved->waypoints;
    g.fixed.assign(g.guess_m.size(), 1);
    g.min_length_m.assign(g.guess_m.size() - 1, 0.0);
    grid.uavs.push_back(std::move(g));
    sub.uavs.push_back(problem.uavs[static_cast<std::size_t>(j)]);
  }
  grid.uavs.push_back(team.uavs[static_cast<std::size_t>(i)]);  // last: processed after them
  sub.uavs.push_back(problem.uavs[static_cast<std::size_t>(i)]);
  for (const GridUav& g : grid.uavs) grid.max_index = std::max(grid.max_index, g.segments());
  TrajectoryOptimizerOptions o = options;
  o.deconflict_guesses = true;
  o.guess_separation_factor = std::max(2.0, options.guess_separation_factor);
  deconflict_team(sub, o, grid);
  return grid.uavs.back();
}

// A UAV solved against `others`; when that fails (short of the time budget), once more from
// its guess moved away from them.
Outcome solve_uav(const TrajectoryProblem& problem, const TrajectoryOptimizerOptions& options,
                  const TeamGrid& team, int i,
                  const std::vector<std::pair<int, const Solved*>>& others, CpuMeter& meter,
                  const std::vector<Vec3>* from = nullptr) {
  Outcome first = UavSolver(problem, options, team, i).solve(others, meter, from);
  if (first.solved || first.status == TrajectoryStatus::kTimeLimit || others.empty()) return first;
  const GridUav moved = guess_around(problem, options, team, i, others);
  Outcome second = UavSolver(problem, options, team, i, &moved).solve(others, meter);
  if (!second.solved) {
    second.message = first.message + "; again from a guess moved away from the others: " +
                     second.message;
    if (second.blocker < 0) second.blocker = first.blocker;
  }
  return second;
}

}  // namespace

TrajectoryResult optimize_in_priority_order(const TrajectoryProblem& problem,
                                            const TrajectoryOptimizerOptions& options,
                                            const TeamGrid& team, TrajectoryResult result,
                                            Clock::time_point start, CpuBudget& budget) {
  const int n = static_cast<int>(team.uavs.size());
  result.decomposed = true;
  auto fail = [&](TrajectoryStatus status, std::string message) {
    result.status = status;
    result.message = std::move(message);
    result.paths.clear();
    result.timing.clear();
    result.costs.clear();
    result.total_time_s = seconds_since(start);
    return result;
  };
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return team.uavs[a].segments() < team.uavs[b].segments();
  });

  std::vector<std::optional<Solved>> solved(n);
  bool any_refined = false;
  auto tally = [&] {
    result.ipopt_iterations = result.solves = result.variables = result.constraints =
        result.separation_rows = result.feasible_stops = 0;
    result.solve_time_s = 0.0;
    for (const auto& s : solved) {
      if (!s) continue;
      result.ipopt_iterations += s->iterations;
      result.solves += s->solves;
      result.variables += s->variables;
      result.constraints += s->constraints;
      result.separation_rows += s->obstacle_rows;
      result.solve_time_s += s->solve_time_s;
      result.feasible_stops += s->feasible_stop ? 1 : 0;
    }
  };
  const std::vector<std::vector<int>> deps = couplings(team, order, options.coupling_distance_m);
  std::vector<int> rank(n);
  for (int a = 0; a < n; ++a) rank[order[a]] = a;

  // Workers take the first UAV in order whose couplings are solved. A UAV that cannot be solved
  // against an earlier one (its route or its hold boxed in by that one's reference: Ipopt
  // stops infeasible, or every refinement is still too close) is solved again without that
  // blocker — it takes priority over it — and the blocker yields: the repair below re-solves it
  // against every other UAV. A failure does not stop the other workers (short of the time
  // budget): every UAV that does not depend on a failed one is solved, so the failure reported
  // is the first in order whatever the thread count and timing.
  std::vector<char> state(n, 0);  // 0 open, 1 taken, 2 blocked by a failed coupling
  std::map<int, Outcome> failures;
  std::set<std::pair<int, int>> yields;  // (blocker, the UAV that took priority over it)
  bool out_of_time = false;
  std::mutex mutex;
  std::condition_variable changed;
  auto worker = [&] {
    CpuMeter meter(budget);
    std::unique_lock lock(mutex);
    while (true) {
      int next = -1;
      bool waiting = false;
      for (int i : order) {
        if (state[i] != 0) continue;
        bool ready = true, blocked = false;
        for (int j : deps[i]) {
          blocked = blocked || failures.count(j) != 0 || state[j] == 2;
          ready = ready && solved[j].has_value();
        }
        if (blocked) {
          state[i] = 2;
        } else if (ready) {
          next = i;
          break;
        } else {
          waiting = true;
        }
      }
      if (out_of_time || (next < 0 && !waiting)) return;
      if (next < 0) {
        changed.wait(lock);
        continue;
      }
      state[next] = 1;
      std::vector<std::pair<int, const Solved*>> others;
      for (int j : deps[next]) others.emplace_back(j, &*solved[j]);
      lock.unlock();
      Outcome outcome = solve_uav(problem, options, team, next, others, meter);
      std::vector<int> passed;  // blockers this UAV took priority over
      for (int swap = 0; !outcome.solved && outcome.status != TrajectoryStatus::kTimeLimit &&
                         outcome.blocker >= 0 && swap < options.max_priority_swaps;
           ++swap) {
        const int blocker = outcome.blocker;
        passed.push_back(blocker);
        std::erase_if(others, [&](const auto& o) { return o.first == blocker; });
        Outcome again = solve_uav(problem, options, team, next, others, meter);
        if (!again.solved) again.message = outcome.message + "; without " +
                                           team.uavs[static_cast<std::size_t>(blocker)].name +
                                           ": " + again.message;
        outcome = std::move(again);
      }
      lock.lock();
      if (!outcome.solved) {
        out_of_time = out_of_time || outcome.status == TrajectoryStatus::kTimeLimit;
        failures.emplace(next, std::move(outcome));
      } else {
        any_refined = any_refined || !passed.empty() ||
                      outcome.status == TrajectoryStatus::kSolvedAfterRefinement;
        for (int b : passed) yields.insert({b, next});
        solved[next] = std::move(outcome.solved);
      }
      changed.notify_all();
    }
  };
  const int threads = std::clamp(options.threads, 1, std::max(1, n));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  tally();
  result.priority_swaps = static_cast<int>(yields.size());
  if (!failures.empty()) {
    const auto first = std::min_element(failures.begin(), failures.end(), [&](const auto& a, const auto& b) {
      return rank[a.first] < rank[b.first];
    });
    return fail(first->second.status, first->second.message);
  }

  // The whole team, every pair: UAVs that were not coupled by their guesses may still meet; the
  // later one is re-solved against all the others.
  PlanValidationOptions validation;
  validation.terrain_step_m = options.validation_terrain_step_m;
  validation.separation_period_s = options.validation_separation_period_s;
  CpuMeter repair_meter(budget);
  for (int repair = 0;; ++repair) {
    std::vector<TimedPath> flown;
    for (int i = 0; i < n; ++i) {
      flown.push_back(solved[i]->flown);
      flown.back().name = team.uavs[i].name;
    }
    result.validation = validate_plan(*problem.terrain, flown, problem.limits, validation);
    if (result.validation.passed()) break;
    std::vector<int> redo;
    for (const PlanViolation& v : result.validation.violations) {
      if (v.kind != ViolationKind::kSeparation) return fail(TrajectoryStatus::kValidationFailed, v.description);
      // The later one, or the blocker that yielded to the other (above).
      int again = rank[v.uav] > rank[v.other_uav] ? v.uav : v.other_uav;
      if (yields.count({v.uav, v.other_uav}) != 0) again = v.uav;
      if (yields.count({v.other_uav, v.uav}) != 0) again = v.other_uav;
      if (std::find(redo.begin(), redo.end(), again) == redo.end()) redo.push_back(again);
    }
    if (repair >= options.max_refinements)
      return fail(TrajectoryStatus::kValidationFailed,
                  "the team's references break a hard constraint after " +
                      std::to_string(repair) + " repair round(s): " + result.validation.summary(3));
    for (int i : redo) {
      // From its own solution, against every other UAV.
      std::vector<std::pair<int, const Solved*>> others;
      for (int j = 0; j < n; ++j)
        if (j != i) others.emplace_back(j, &*solved[j]);
      const std::vector<Vec3> from = solved[i]->waypoints;
      Outcome outcome = solve_uav(problem, options, team, i, others, repair_meter, &from);
      if (!outcome.solved) {
        tally();
        return fail(outcome.status, outcome.message);
      }
      outcome.solved->initial_cost = solved[i]->initial_cost;  // J of the guess, as first solved
      outcome.solved->initial_objective = solved[i]->initial_objective;
      outcome.solved->iterations += solved[i]->iterations;
      outcome.solved->solves += solved[i]->solves;
      outcome.solved->solve_time_s += solved[i]->solve_time_s;
      solved[i] = std::move(outcome.solved);
      any_refined = true;
    }
    tally();
  }

  result.status = any_refined ? TrajectoryStatus::kSolvedAfterRefinement : TrajectoryStatus::kSolved;
  result.message.clear();
  result.paths.clear();
  result.timing.clear();
  result.costs.clear();
  result.initial_costs.clear();
  result.objective = result.initial_objective = 0.0;
  result.collision_cost = result.initial_collision_cost = 0.0;
  for (int i = 0; i < n; ++i) {
    Solved& s = *solved[i];
    TimedPath path;
    path.name = team.uavs[i].name;
    path.waypoints_m = s.waypoints;
    for (std::size_t k = 0; k < s.waypoints.size(); ++k) path.times_s.push_back(k * team.dt);
    result.paths.push_back(std::move(path));
    result.timing.push_back(std::move(s.timing));
    result.costs.push_back(s.cost);
    result.initial_costs.push_back(s.initial_cost);
    result.objective += s.objective;
    result.initial_objective += s.initial_objective;
  }
  result.total_time_s = seconds_since(start);
  return result;
}

}  // namespace ridgeline::planning::detail
