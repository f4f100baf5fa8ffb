#include "planning/guess_deconfliction.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/error.hpp"

namespace ridgeline::planning {
namespace {

// Position of a guess at time t (in grid steps): linear between points, held after the end.
Vec3 sample(const std::vector<Vec3>& path, double t) {
  const int n = static_cast<int>(path.size()) - 1;
  if (t >= n) return path.back();
  const int k = static_cast<int>(std::floor(t));
  const double a = t - k;
  return (1.0 - a) * path[k] + a * path[k + 1];
}

// Independent reference: the minimum separation sampled 200 times a step.
double brute_min_separation(const std::vector<GuessUav>& uavs) {
  double best = std::numeric_limits<double>::infinity();
  std::size_t steps = 0;
  for (const GuessUav& u : uavs) steps = std::max(steps, u.guess_m.size());
  for (double t = 0.0; t <= static_cast<double>(steps); t += 1.0 / 200.0)
    for (std::size_t a = 0; a < uavs.size(); ++a)
      for (std::size_t b = a + 1; b < uavs.size(); ++b)
        best = std::min(best, (sample(uavs[a].guess_m, t) - sample(uavs[b].guess_m, t)).norm());
  return best;
}

// A straight guess from a to b in n steps, ends fixed.
GuessUav straight(const Vec3& a, const Vec3& b, int n, double climb_step_m = 3.0) {
  GuessUav u;
  for (int k = 0; k <= n; ++k) {
    u.guess_m.push_back(a + (b - a) * (static_cast<double>(k) / n));
    u.fixed.push_back(k == 0 || k == n ? 1 : 0);
  }
  u.max_climb_step_m = climb_step_m;
  return u;
}

TEST(GuessDeconflictionTest, StepMinimumMatchesDenseSampling) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-100.0, 100.0);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<Vec3> a = {Vec3(pos(rng), pos(rng), pos(rng)), Vec3(pos(rng), pos(rng), pos(rng))};
    std::vector<Vec3> b = {Vec3(pos(rng), pos(rng), pos(rng)), Vec3(pos(rng), pos(rng), pos(rng))};
    double brute = std::numeric_limits<double>::infinity();
    for (int s = 0; s <= 20000; ++s) {
      const double t = s / 20000.0;
      brute = std::min(brute, (sample(a, t) - sample(b, t)).norm());
    }
    // The sampled minimum is above the exact one by at most the relative speed × half a sample
    // (|Δr| ≤ 2·√3·200 m over the step → ≤ 0.035 m at 1/20000).
    const double exact = step_min_distance(a, b, 0);
    EXPECT_LE(exact, brute + 1e-9);
    EXPECT_GE(exact, brute - 0.035);
  }
}

TEST(GuessDeconflictionTest, HeadOnCrossingIsLiftedIntoALayer) {
  // Two UAVs cross at the same altitude in the middle of 20 steps of 10 m.
  std::vector<GuessUav> uavs = {straight({0, 0, 100}, {200, 0, 100}, 20),
                                straight({100, -100, 100}, {100, 100, 100}, 20)};
  const std::vector<GuessUav> before = uavs;
  GuessDeconflictionOptions options;
  options.separation_m = 20.0;
  const GuessDeconflictionSummary s = deconflict_guesses(uavs, world::AltitudeBand{}, options);
  EXPECT_LT(s.min_separation_before_m, 1e-6);
  EXPECT_EQ(s.conflicts_after, 0);
  EXPECT_EQ(s.lifted_uavs, 1);
  EXPECT_EQ(s.delayed_uavs, 0);
  EXPECT_GE(brute_min_separation(uavs), 20.0 - 1e-6);
  EXPECT_NEAR(s.min_separation_after_m, brute_min_separation(uavs), 0.05);
  for (std::size_t i = 0; i < uavs.size(); ++i) {
    ASSERT_EQ(uavs[i].guess_m.size(), before[i].guess_m.size());
    for (std::size_t k = 0; k < uavs[i].guess_m.size(); ++k) {
      // Only z rises, fixed points stay, and the climb per step stays within the budget.
      EXPECT_DOUBLE_EQ(uavs[i].guess_m[k].x(), before[i].guess_m[k].x());
      EXPECT_DOUBLE_EQ(uavs[i].guess_m[k].y(), before[i].guess_m[k].y());
      EXPECT_GE(uavs[i].guess_m[k].z(), before[i].guess_m[k].z());
      if (uavs[i].fixed[k]) {
        EXPECT_EQ(uavs[i].guess_m[k], before[i].guess_m[k]);
      }
      if (k > 0) {
        EXPECT_LE(std::abs(uavs[i].guess_m[k].z() - uavs[i].guess_m[k - 1].z()),
                  uavs[i].max_climb_step_m + 1e-9);
      }
    }
  }
}

TEST(GuessDeconflictionTest, CrossingWhileClimbingAtTheLimitIsDelayed) {
  // Both climb at exactly the climb budget (3 m a step), so no lift is possible; their tracks
  // cross 7 steps after two starts 140 m apart.
  std::vector<GuessUav> uavs = {straight({0, 0, 50}, {300, 300, 140}, 30),
                                straight({140, 0, 50}, {-160, 300, 140}, 30)};
  // Give the second a longer route, so it is processed (and moved) second.
  GuessUav& second = uavs[1];
  second.guess_m.push_back(Vec3(-170, 310, 140));
  second.fixed.push_back(1);
  const std::vector<Vec3> fixed_before = {second.guess_m.front(), second.guess_m[30],
                                          second.guess_m.back()};
  const GuessDeconflictionSummary s = deconflict_guesses(uavs, world::AltitudeBand{});
  EXPECT_LT(s.min_separation_before_m, 5.0);
  EXPECT_EQ(s.conflicts_after, 0);
  EXPECT_EQ(s.delayed_uavs, 1);
  EXPECT_GE(brute_min_separation(uavs), 20.0 - 1e-6);
  // The delayed guess keeps its fixed points, in order, and flies no faster than before.
  std::vector<Vec3> fixed_after;
  for (std::size_t k = 0; k < second.guess_m.size(); ++k)
    if (second.fixed[k]) fixed_after.push_back(second.guess_m[k]);
  ASSERT_EQ(fixed_after.size(), fixed_before.size());
  for (std::size_t q = 0; q < fixed_after.size(); ++q)
    EXPECT_LT((fixed_after[q] - fixed_before[q]).norm(), 1e-9);
  EXPECT_GT(second.guess_m.size(), 32u);
  for (std::size_t k = 1; k < second.guess_m.size(); ++k)
    EXPECT_LE((second.guess_m[k] - second.guess_m[k - 1]).norm(),
              (uavs[0].guess_m[1] - uavs[0].guess_m[0]).norm() + 1e-9);
}

TEST(GuessDeconflictionTest, RandomTeamsNeverGetWorseAndKeepTheirLimits) {
  // Property test: random teams of 6 on crossing routes. Whatever is left, a UAV's fixed points
  // stay, z stays within H_max and the climb budget, and a reported zero-conflict result is
  // confirmed by dense sampling.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(0.0, 400.0);
  std::uniform_real_distribution<double> alt(60.0, 120.0);
  int resolved = 0;
  for (int trial = 0; trial < 30; ++trial) {
    std::vector<GuessUav> uavs;
    for (int i = 0; i < 6; ++i) {
      const Vec3 a(pos(rng), pos(rng), alt(rng));
      const Vec3 b(pos(rng), pos(rng), alt(rng));
      const int n = 20 + static_cast<int>(rng() % 10);
      GuessUav u = straight(a, b, n, std::max(3.0, std::abs(b.z() - a.z()) / n + 0.5));
      u.max_grade = 0.3;  // the pitch limit: a lift's ramp must keep it on short (slow) steps too
      uavs.push_back(u);
    }
    const std::vector<GuessUav> before = uavs;
    GuessDeconflictionOptions options;
    const world::AltitudeBand band{40.0, 300.0};
    const GuessDeconflictionSummary s = deconflict_guesses(uavs, band, options);
    if (s.conflicts_after == 0) {
      ++resolved;
      EXPECT_GE(brute_min_separation(uavs), options.separation_m - 1e-6) << "trial " << trial;
    }
    EXPECT_LE(s.conflicts_after, s.conflicts_before);
    for (std::size_t i = 0; i < uavs.size(); ++i) {
      const GuessUav& u = uavs[i];
      EXPECT_EQ(u.guess_m.front(), before[i].guess_m.front());
      EXPECT_EQ(u.guess_m.back(), before[i].guess_m.back());
      EXPECT_TRUE(u.fixed.back());
      for (std::size_t k = 0; k < u.guess_m.size(); ++k) {
        EXPECT_LE(u.guess_m[k].z(), band.max_m + 1e-9);
        if (k > 0) {
          const double climb_m = std::abs(u.guess_m[k].z() - u.guess_m[k - 1].z());
          EXPECT_LE(climb_m, u.max_climb_step_m + 1e-9);
          // A route within the grade keeps it after lifts and delays.
          const Vec3 route = before[i].guess_m.back() - before[i].guess_m.front();
          if (std::abs(route.z()) <= u.max_grade * route.head<2>().norm()) {
            EXPECT_LE(climb_m,
                      u.max_grade * (u.guess_m[k] - u.guess_m[k - 1]).head<2>().norm() + 1e-9)
                << "trial " << trial << " uav " << i << " step " << k;
          }
        }
      }
    }
  }
  // Most random teams are fully separated (the rest start or end too close to be helped).
  EXPECT_GE(resolved, 20);
}

TEST(GuessDeconflictionTest, BadOptionsNameTheField) {
  std::vector<GuessUav> uavs = {straight({0, 0, 100}, {200, 0, 100}, 20)};
  GuessDeconflictionOptions options;
  options.separation_m = std::nan("");
  try {
    deconflict_guesses(uavs, world::AltitudeBand{}, options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "guess_deconfliction.separation_m");
  }
  options = {};
  options.slow_speed_ratio = 1.0;
  EXPECT_THROW(deconflict_guesses(uavs, world::AltitudeBand{}, options), InputError);
  uavs[0].fixed.pop_back();
  EXPECT_THROW(deconflict_guesses(uavs, world::AltitudeBand{}), InputError);
}

}  // namespace
}  // namespace ridgeline::planning
