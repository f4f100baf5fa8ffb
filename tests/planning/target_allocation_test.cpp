#include "planning/target_allocation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"

namespace ridgeline::planning {
namespace {

using Routes = std::vector<std::vector<int>>;

// Random instance in the 2 km × 2 km default area: costs are 3-D Euclidean distances
// (metric, as real flight costs are), priorities drawn from {1, 2, 3}.
AllocationProblem random_problem(Rng& rng, int n_uav, int n_target) {
  AllocationProblem p;
  for (int i = 0; i < n_uav; ++i) {
    p.uav_starts_m.emplace_back(rng.uniform(0.0, 2000.0), rng.uniform(0.0, 2000.0), 100.0);
  }
  for (int j = 0; j < n_target; ++j) {
    std::string name = "T";  // built by append: GCC 12 warns falsely on "T" + std::to_string
    name += std::to_string(j);
    p.targets.push_back(
        {name, Vec3(rng.uniform(0.0, 2000.0), rng.uniform(0.0, 2000.0), rng.uniform(60.0, 300.0)),
         1 + static_cast<int>(rng.uniform(0.0, 3.0))});
  }
  p.start_cost.resize(n_uav, n_target);
  p.target_cost = MatX::Zero(n_target, n_target);
  for (int i = 0; i < n_uav; ++i) {
    for (int j = 0; j < n_target; ++j)
      p.start_cost(i, j) = (p.uav_starts_m[i] - p.targets[j].position_m).norm();
  }
  for (int j = 0; j < n_target; ++j) {
    for (int k = 0; k < n_target; ++k)
      p.target_cost(j, k) = (p.targets[j].position_m - p.targets[k].position_m).norm();
  }
  return p;
}

// Independent reference: every permutation of the targets cut into n_uav consecutive (possibly
// empty) routes covers every allocation with every visiting order; keep the best
// priority-feasible one under allocation_objective.
double brute_force_optimum(const AllocationProblem& p, const AllocationOptions& options,
                           int max_per_uav) {
  const int n_uav = static_cast<int>(p.uav_starts_m.size());
  const int n_target = static_cast<int>(p.targets.size());
  std::vector<int> perm(n_target);
  std::iota(perm.begin(), perm.end(), 0);
  double best = std::numeric_limits<double>::infinity();
  std::vector<int> cuts(n_uav - 1, 0);  // non-decreasing cut positions in [0, n_target]
  do {
    std::fill(cuts.begin(), cuts.end(), 0);
    while (true) {
      Routes routes(n_uav);
      int begin = 0;
      bool ok = true;
      for (int i = 0; i < n_uav; ++i) {
        const int end = i + 1 < n_uav ? cuts[i] : n_target;
        routes[i].assign(perm.begin() + begin, perm.begin() + end);
        ok = ok && static_cast<int>(routes[i].size()) <= max_per_uav;
        begin = end;
      }
      if (ok && routes_respect_priority(p, routes))
        best = std::min(best, allocation_objective(p, routes, options));
      // Next non-decreasing cut vector.
      int k = n_uav - 2;
      while (k >= 0 && cuts[k] == n_target) --k;
      if (k < 0) break;
      ++cuts[k];
      for (int l = k + 1; l < n_uav - 1; ++l) cuts[l] = cuts[k];
    }
  } while (std::next_permutation(perm.begin(), perm.end()));
  return best;
}

void expect_valid_allocation(const AllocationProblem& p, const AllocationResult& r) {
  const int n_target = static_cast<int>(p.targets.size());
  std::vector<int> seen(n_target, 0);
  for (const auto& route : r.routes) {
    for (int j : route) ++seen[j];
  }
  for (int j = 0; j < n_target; ++j) EXPECT_EQ(seen[j], 1) << "target " << j;
  EXPECT_TRUE(routes_respect_priority(p, r.routes));
}

TEST(SolveAssignment, MatchesBruteForceOn200RandomSquareInstances) {
  Rng rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + trial % 7;
    MatX c(n, n);
    for (int r = 0; r < n; ++r) {
      for (int k = 0; k < n; ++k) c(r, k) = rng.uniform(0.0, 100.0);
    }
    const Assignment a = solve_assignment(c);
    ASSERT_TRUE(a.feasible);
    std::vector<int> perm(n);
    std::iota(perm.begin(), perm.end(), 0);
    double best = std::numeric_limits<double>::infinity();
    do {
      double s = 0.0;
      for (int r = 0; r < n; ++r) s += c(r, perm[r]);
      best = std::min(best, s);
    } while (std::next_permutation(perm.begin(), perm.end()));
    // Sums of ≤ 7 numbers ≤ 100 in double: 1e-9 is far above round-off, far below any gap.
    EXPECT_NEAR(a.total_cost, best, 1e-9) << "trial " << trial;
    std::vector<int> cols = a.row_to_col;
    std::sort(cols.begin(), cols.end());
    EXPECT_TRUE(std::adjacent_find(cols.begin(), cols.end()) == cols.end());
  }
}

TEST(SolveAssignment, RectangularAndForbiddenPairs) {
  const double inf = std::numeric_limits<double>::infinity();
  MatX c(2, 3);
  c << 5, 1, inf,  //
      inf, 2, 9;
  const Assignment a = solve_assignment(c);
  ASSERT_TRUE(a.feasible);
  // Row 0 must take column 1 or 0; the optimum is row0→0 (5) + row1→1 (2) = 7 < 1 + 9 = 10.
  EXPECT_EQ(a.row_to_col, (std::vector<int>{0, 1}));
  EXPECT_DOUBLE_EQ(a.total_cost, 7.0);

  MatX blocked(2, 2);
  blocked << 1, inf,  //
      2, inf;
  EXPECT_FALSE(solve_assignment(blocked).feasible);
  EXPECT_THROW(solve_assignment(MatX::Zero(3, 2)), std::invalid_argument);
}

TEST(AllocateTargets, OneTargetPerUavIsExactOn200RandomInstances) {
  Rng rng(5);
  const AllocationOptions options;  // λ = 1, β = 0.1: the makespan sweep is exercised
  for (int trial = 0; trial < 200; ++trial) {
    const int n_target = 1 + trial % 7;
    const int n_uav = n_target + (trial % 3 == 0 ? 1 : 0);  // equal counts, and one spare UAV
    const AllocationProblem p = random_problem(rng, n_uav, n_target);
    const AllocationResult r = allocate_targets(p, options);
    ASSERT_EQ(r.status, AllocationStatus::kOptimal) << r.message;
    expect_valid_allocation(p, r);
    for (const auto& route : r.routes) EXPECT_LE(route.size(), 1u);
    // Reference: every injective map targets → UAVs (first n_target entries of a permutation).
    std::vector<int> perm(n_uav);
    std::iota(perm.begin(), perm.end(), 0);
    double best = std::numeric_limits<double>::infinity();
    do {
      Routes routes(n_uav);
      for (int j = 0; j < n_target; ++j) routes[perm[j]].push_back(j);
      best = std::min(best, allocation_objective(p, routes, options));
    } while (std::next_permutation(perm.begin(), perm.end()));
    // Costs are O(1e3) m summed over ≤ 8 terms: 1e-6 relative is round-off only.
    EXPECT_NEAR(r.objective, best, 1e-6 * best) << "trial " << trial;
  }
}

struct GapStats {
  double mean = 0.0;
  double worst = 0.0;
  int optimal = 0;
};

GapStats heuristic_gaps(const AllocationOptions& options) {
  Rng rng(2024);
  GapStats stats;
  const int trials = 200;
  for (int trial = 0; trial < trials; ++trial) {
    const int n_uav = 1 + trial % 3;
    const int n_target = n_uav + 1 + static_cast<int>(rng.uniform(0.0, 6.0 - n_uav));
    const AllocationProblem p = random_problem(rng, n_uav, n_target);
    const AllocationResult r = allocate_targets(p, options);
    EXPECT_EQ(r.status, AllocationStatus::kHeuristic) << r.message;
    expect_valid_allocation(p, r);
    EXPECT_NEAR(r.objective, allocation_objective(p, r.routes, options), 1e-9 * r.objective);
    const double best = brute_force_optimum(p, options, n_target);
    const double gap = (r.objective - best) / best;
    EXPECT_GE(gap, -1e-12);  // brute force is the optimum
    stats.mean += gap / trials;
    stats.worst = std::max(stats.worst, gap);
    if (gap < 1e-9) ++stats.optimal;
  }
  return stats;
}

TEST(AllocateTargets, HeuristicWithinStatedGapOfBruteForce) {
  // 200 random instances, 1–3 UAVs, 2–6 targets, more targets than UAVs.
  // Measured (seed 2024): constructions + local search alone: mean 0.14 %, worst 11.3 %,
  // optimal in 195/200; with the default 30 iterated-local-search rounds: optimal in 200/200.
  // Stated bounds, with headroom for other seeds: descent alone mean ≤ 1 %, worst ≤ 15 %;
  // default options mean ≤ 0.5 %, worst ≤ 5 %.
  AllocationOptions descent_only;
  descent_only.perturbation_rounds = 0;
  const GapStats plain = heuristic_gaps(descent_only);
  const GapStats ils = heuristic_gaps(AllocationOptions{});
  std::printf("descent only: mean gap %.3f %%, worst %.3f %%, optimal %d/200\n", 100 * plain.mean,
              100 * plain.worst, plain.optimal);
  std::printf("default (ILS): mean gap %.3f %%, worst %.3f %%, optimal %d/200\n", 100 * ils.mean,
              100 * ils.worst, ils.optimal);
  EXPECT_LE(plain.mean, 0.01);
  EXPECT_LE(plain.worst, 0.15);
  EXPECT_LE(ils.mean, 0.005);
  EXPECT_LE(ils.worst, 0.05);
}

TEST(AllocateTargets, PriorityOrderHoldsOnLargerInstancesAndIsDeterministic) {
  Rng rng(77);
  for (int trial = 0; trial < 20; ++trial) {
    const AllocationProblem p = random_problem(rng, 3, 12);
    const AllocationResult a = allocate_targets(p);
    const AllocationResult b = allocate_targets(p);
    ASSERT_EQ(a.status, AllocationStatus::kHeuristic);
    expect_valid_allocation(p, a);
    EXPECT_EQ(a.routes, b.routes);
  }
}

TEST(AllocateTargets, PriorityWeightPullsImportantTargetFirst) {
  // One UAV at the origin, targets on a line: "near" at 100 m (priority 1) and "far" at 1000 m
  // (priority 5). The order rule alone forces far before near despite the longer route.
  AllocationProblem p;
  p.uav_starts_m = {Vec3(0, 0, 100)};
  p.targets = {{"near", Vec3(100, 0, 100), 1}, {"far", Vec3(1000, 0, 100), 5}};
  p.start_cost.resize(1, 2);
  p.start_cost << 100, 1000;
  p.target_cost.resize(2, 2);
  p.target_cost << 0, 900, 900, 0;
  const AllocationResult r = allocate_targets(p);
  ASSERT_EQ(r.status, AllocationStatus::kHeuristic);
  EXPECT_EQ(r.routes[0], (std::vector<int>{1, 0}));
  // C = 1000 + 900; J = λ·C + C + β·π_far·A_far = 1900 + 1900 + 0.1·4·1000.
  EXPECT_NEAR(r.objective, 1900 + 1900 + 0.1 * 4 * 1000, 1e-9);
}

// Per-UAV missions: some targets required of one UAV, some UAVs with an end (return home).
// Brute force scores every split and order with allocation_objective, which charges the end
// legs and makes a route holding another UAV's required target infinitely expensive.
TEST(AllocateTargets, RequiredTargetsStayOnTheirUavAndEndLegsCountAgainstBruteForce) {
  Rng rng(4242);
  int optimal = 0;
  double worst_gap = 0.0;
  constexpr int kTrials = 60;
  for (int trial = 0; trial < kTrials; ++trial) {
    const int n_uav = 2 + trial % 2;
    const int n_target = 3 + trial % 4;
    AllocationProblem p = random_problem(rng, n_uav, n_target);
    p.required_uav.assign(n_target, -1);
    for (int j = 0; j < n_target; ++j) {
      if (rng.uniform() < 0.35)
        p.required_uav[j] = std::min(n_uav - 1, static_cast<int>(rng.uniform() * n_uav));
    }
    p.end_cost = MatX::Zero(n_uav, n_target);
    p.start_end_cost.assign(n_uav, 0.0);
    for (int i = 0; i < n_uav; ++i) {
      if (rng.uniform() < 0.5) continue;  // this UAV has no end
      const Vec3 end = p.uav_starts_m[i] + Vec3(rng.uniform(-300, 300), rng.uniform(-300, 300), 0);
      p.start_end_cost[i] = (end - p.uav_starts_m[i]).norm();
      for (int j = 0; j < n_target; ++j) p.end_cost(i, j) = (end - p.targets[j].position_m).norm();
    }
    const AllocationResult r = allocate_targets(p);
    ASSERT_NE(r.status, AllocationStatus::kInvalidInput) << r.message;
    expect_valid_allocation(p, r);
    for (int j = 0; j < n_target; ++j) {
      if (p.required_uav[j] >= 0) {
        EXPECT_EQ(r.uav_of_target[j], p.required_uav[j]) << "target " << j;
      }
    }
    // The reported objective is the routes' own J, end legs included.
    EXPECT_NEAR(r.objective, allocation_objective(p, r.routes, AllocationOptions{}), 1e-6);
    const double best = brute_force_optimum(p, AllocationOptions{}, n_target);
    ASSERT_TRUE(std::isfinite(best));
    const double gap = (r.objective - best) / best;
    EXPECT_GE(gap, -1e-9);  // never better than the optimum: the brute force is the reference
    worst_gap = std::max(worst_gap, gap);
    if (gap < 1e-9) ++optimal;
  }
  std::printf("required targets and ends: optimal %d/%d, worst gap %.3f %%\n", optimal, kTrials,
              100 * worst_gap);
  EXPECT_LE(worst_gap, 0.05);  // the heuristic's stated bound (file comment)
}

TEST(AllocateTargets, AnEndMakesTheCloserUavTakeTheTargetOnItsWayHome) {
  // Two UAVs at x = 0 and x = 1000, one target at x = 400. Without ends the UAV at 0 is closer
  // (400 against 600); when the UAV at 0 must end at x = -1000 and the one at 1000 ends at x = 0,
  // the second one's detour is the cheaper (600 + 400 against 400 + 1400).
  AllocationProblem p;
  p.uav_starts_m = {Vec3(0, 0, 100), Vec3(1000, 0, 100)};
  p.targets = {{"t", Vec3(400, 0, 100), 1}};
  p.start_cost.resize(2, 1);
  p.start_cost << 400, 600;
  p.target_cost = MatX::Zero(1, 1);
  EXPECT_EQ(allocate_targets(p).uav_of_target[0], 0);
  p.end_cost.resize(2, 1);
  p.end_cost << 1400, 400;
  p.start_end_cost = {1000, 1000};
  const AllocationResult r = allocate_targets(p);
  EXPECT_EQ(r.status, AllocationStatus::kHeuristic);
  EXPECT_EQ(r.uav_of_target[0], 1);
  // C_0 = 1000 (straight to its end), C_1 = 600 + 400: J = λ·1000 + 2000.
  EXPECT_NEAR(r.objective, 1000 + 2000, 1e-9);
  // Required of UAV 0, it goes there whatever it costs.
  p.required_uav = {0};
  EXPECT_EQ(allocate_targets(p).uav_of_target[0], 0);
  p.required_uav = {2};
  const AllocationResult bad = allocate_targets(p);
  EXPECT_EQ(bad.status, AllocationStatus::kInvalidInput);
  EXPECT_NE(bad.message.find("required_uav[0]"), std::string::npos) << bad.message;
}

TEST(AllocateTargets, SpareUavsGetNoTarget) {
  Rng rng(3);
  const AllocationProblem p = random_problem(rng, 5, 2);
  const AllocationResult r = allocate_targets(p);
  ASSERT_EQ(r.status, AllocationStatus::kOptimal);
  int idle = 0;
  for (std::size_t i = 0; i < r.routes.size(); ++i) {
    if (r.routes[i].empty()) {
      ++idle;
      EXPECT_EQ(r.route_cost[i], 0.0);
    }
  }
  EXPECT_EQ(idle, 3);
}

TEST(AllocateTargets, DegenerateInputsAreErrorsNamingTheField) {
  Rng rng(1);
  AllocationProblem p = random_problem(rng, 2, 3);

  AllocationProblem no_uav = p;
  no_uav.uav_starts_m.clear();
  no_uav.start_cost.resize(0, 3);
  AllocationResult r = allocate_targets(no_uav);
  EXPECT_EQ(r.status, AllocationStatus::kInvalidInput);
  EXPECT_NE(r.message.find("uav_starts_m"), std::string::npos) << r.message;

  AllocationProblem no_target = p;
  no_target.targets.clear();
  no_target.start_cost.resize(2, 0);
  no_target.target_cost.resize(0, 0);
  r = allocate_targets(no_target);
  EXPECT_EQ(r.status, AllocationStatus::kInvalidInput);
  EXPECT_NE(r.message.find("targets"), std::string::npos) << r.message;

  AllocationProblem nan_cost = p;
  nan_cost.start_cost(1, 2) = std::nan("");
  r = allocate_targets(nan_cost);
  EXPECT_EQ(r.status, AllocationStatus::kInvalidInput);
  EXPECT_NE(r.message.find("start_cost(1, 2)"), std::string::npos) << r.message;

  AllocationProblem negative = p;
  negative.target_cost(0, 1) = -1.0;
  r = allocate_targets(negative);
  EXPECT_EQ(r.status, AllocationStatus::kInvalidInput);
  EXPECT_NE(r.message.find("target_cost(0, 1)"), std::string::npos) << r.message;

  AllocationProblem wrong_size = p;
  wrong_size.start_cost.resize(3, 3);
  r = allocate_targets(wrong_size);
  EXPECT_EQ(r.status, AllocationStatus::kInvalidInput);
  EXPECT_NE(r.message.find("start_cost"), std::string::npos) << r.message;

  AllocationOptions bad;
  bad.makespan_weight = -1.0;
  r = allocate_targets(p, bad);
  EXPECT_EQ(r.status, AllocationStatus::kInvalidInput);
  EXPECT_NE(r.message.find("makespan_weight"), std::string::npos) << r.message;
}

TEST(EstimateAllocationCosts, FlatTerrainIsStraightLineAndPeaksAddClimb) {
  world::PeakTerrain flat(world::PeakTerrainConfig{});
  const Vec3 a(0, 0, 100), b(1000, 500, 150);
  // Each sample step is an exact chord of the straight line, so the sum is |b − a| to round-off,
  // plus the climb penalty on the line's own 50 m of ascent.
  EXPECT_NEAR(estimate_leg_cost(flat, a, b, world::SafetyLimits{}), (b - a).norm() + 2.0 * 50.0,
              1e-9 * (b - a).norm());

  world::PeakTerrainConfig cfg;
  cfg.peaks.push_back({500, 250, 300, 100, 100});
  world::PeakTerrain hill(cfg);
  CostEstimateOptions options;
  const double cost = estimate_leg_cost(hill, a, b, world::SafetyLimits{}, options);
  // The profile must climb from ≈ 125 m to ≈ 320 m (peak + h_safe) and back: at least
  // the straight length plus climb_penalty × 190 m of ascent.
  EXPECT_GT(cost, (b - a).norm() + options.climb_penalty * 190.0);

  const AllocationCosts costs = estimate_allocation_costs(
      hill, {a}, {{"t0", b, 1}, {"t1", a + Vec3(10, 0, 0), 1}}, world::SafetyLimits{});
  EXPECT_EQ(costs.start_cost.rows(), 1);
  EXPECT_EQ(costs.target_cost.rows(), 2);
  EXPECT_EQ(costs.target_cost(0, 0), 0.0);
  CostEstimateOptions bad;
  bad.sample_step_m = 0.0;
  EXPECT_THROW(estimate_allocation_costs(hill, {a}, {{"t0", b, 1}}, world::SafetyLimits{}, bad),
               InputError);
}

}  // namespace
}  // namespace ridgeline::planning
