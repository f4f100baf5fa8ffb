#include "planning/plan_validation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/error.hpp"

namespace ridgeline::planning {
namespace {

using world::Peak;
using world::PeakTerrain;
using world::PeakTerrainConfig;

TimedPath path(const std::string& name, std::vector<Vec3> points, std::vector<double> times) {
  return TimedPath{name, std::move(points), std::move(times)};
}

const PeakTerrain& flat() {
  static const PeakTerrain terrain{PeakTerrainConfig{}};
  return terrain;
}

TEST(PlanValidation, CleanPlanPassesAndReportsExactMinima) {
  const std::vector<TimedPath> paths = {
      path("a", {Vec3(0, 0, 100), Vec3(100, 0, 120)}, {0.0, 10.0}),
      path("b", {Vec3(0, 50, 80), Vec3(100, 50, 90)}, {0.0, 10.0}),
  };
  const PlanValidationReport r = validate_plan(flat(), paths, world::SafetyLimits{});
  EXPECT_TRUE(r.passed()) << r.summary();
  // Flat ground at 0: the clearance is the lowest z; the pair's distance is smallest where
  // the height difference is smallest (t = 0: √(50² + 20²)); both exact at sample points.
  EXPECT_DOUBLE_EQ(r.min_clearance_m, 80.0);
  EXPECT_DOUBLE_EQ(r.min_altitude_m, 80.0);
  EXPECT_DOUBLE_EQ(r.max_altitude_m, 120.0);
  EXPECT_NEAR(r.min_separation_m, std::sqrt(50.0 * 50.0 + 20.0 * 20.0), 1e-12);
}

TEST(PlanValidation, FindsATerrainViolationBetweenWaypoints) {
  // A narrow peak under the middle of a segment whose end points are far above the ground:
  // only the dense sampling sees it.
  PeakTerrainConfig c;
  c.peaks = {Peak{50.0, 0.0, 95.0, 3.0, 3.0}};
  const PeakTerrain terrain(c);
  const std::vector<TimedPath> paths = {path("a", {Vec3(0, 0, 100), Vec3(100, 0, 100)}, {0.0, 10.0})};
  PlanValidationOptions o;
  o.terrain_step_m = 2.0;  // x = 50 is a sample point: the worst sample is the peak itself
  const PlanValidationReport r = validate_plan(terrain, paths, world::SafetyLimits{}, o);
  ASSERT_EQ(r.violations.size(), 1u) << r.summary();
  const PlanViolation& v = r.violations[0];
  EXPECT_EQ(v.kind, ViolationKind::kTerrainClearance);
  EXPECT_EQ(v.uav, 0);
  EXPECT_EQ(v.segment, 0);
  EXPECT_NEAR(v.position_m.x(), 50.0, 1e-9);
  EXPECT_NEAR(v.time_s, 5.0, 1e-9);
  EXPECT_NEAR(v.amount_m, 20.0 - 5.0, 1e-9);  // 5 m above the peak, 20 m required
  EXPECT_NE(v.description.find("terrain clearance"), std::string::npos);
}

TEST(PlanValidation, AddsTheTerrainModelErrorToTheRequiredClearance) {
  PeakTerrainConfig c;
  c.model_error_m = 3.0;
  const PeakTerrain terrain(c);
  const std::vector<TimedPath> paths = {path("a", {Vec3(0, 0, 45), Vec3(100, 0, 45)}, {0.0, 10.0})};
  world::SafetyLimits limits;
  limits.terrain_clearance_m = 43.0;
  const PlanValidationReport r = validate_plan(terrain, paths, limits);
  ASSERT_EQ(r.violations.size(), 1u);
  EXPECT_NEAR(r.violations[0].amount_m, 1.0, 1e-12);  // 45 < 43 + 3
}

TEST(PlanValidation, FindsAltitudeBandViolationsAtWaypoints) {
  const std::vector<TimedPath> paths = {
      path("a", {Vec3(0, 0, 100), Vec3(50, 0, 30), Vec3(100, 0, 510)}, {0.0, 5.0, 10.0})};
  world::SafetyLimits limits;
  limits.terrain_clearance_m = 0.0;
  const PlanValidationReport r = validate_plan(flat(), paths, limits);
  ASSERT_EQ(r.violations.size(), 2u) << r.summary();
  EXPECT_EQ(r.violations[0].kind, ViolationKind::kAltitudeLow);
  EXPECT_EQ(r.violations[0].segment, 1);
  EXPECT_NEAR(r.violations[0].amount_m, 10.0, 1e-12);
  EXPECT_EQ(r.violations[1].kind, ViolationKind::kAltitudeHigh);
  EXPECT_EQ(r.violations[1].segment, 2);
  EXPECT_NEAR(r.violations[1].amount_m, 10.0, 1e-12);
}

TEST(PlanValidation, FindsACrossingBetweenWaypointTimes) {
  // Both cross (50, 0, 100) at t = 5 s, a multiple of the 0.02 s period; the waypoints
  // themselves are 70 m apart.
  const std::vector<TimedPath> paths = {
      path("a", {Vec3(0, 0, 100), Vec3(100, 0, 100)}, {0.0, 10.0}),
      path("b", {Vec3(50, -50, 100), Vec3(50, 50, 100)}, {0.0, 10.0}),
  };
  const PlanValidationReport r = validate_plan(flat(), paths, world::SafetyLimits{});
  ASSERT_EQ(r.violations.size(), 1u) << r.summary();
  const PlanViolation& v = r.violations[0];
  EXPECT_EQ(v.kind, ViolationKind::kSeparation);
  EXPECT_EQ(v.uav, 0);
  EXPECT_EQ(v.other_uav, 1);
  EXPECT_NEAR(v.time_s, 5.0, 1e-9);
  EXPECT_NEAR(v.amount_m, 10.0, 1e-9);
  EXPECT_NEAR((v.position_m - Vec3(50, 0, 100)).norm(), 0.0, 1e-9);
  EXPECT_NEAR(r.min_separation_m, 0.0, 1e-9);
}

TEST(PlanValidation, AFinishedUavHoldsAtItsLastPoint) {
  // a lands its route at (100, 0) at t = 10 s; b passes there at t = 20 s.
  const std::vector<TimedPath> paths = {
      path("a", {Vec3(0, 0, 100), Vec3(100, 0, 100)}, {0.0, 10.0}),
      path("b", {Vec3(100, -100, 100), Vec3(100, 100, 100)}, {10.0, 30.0}),
  };
  const PlanValidationReport r = validate_plan(flat(), paths, world::SafetyLimits{});
  ASSERT_EQ(r.violations.size(), 1u) << r.summary();
  EXPECT_NEAR(r.violations[0].time_s, 20.0, 1e-9);
}

// Cross-check against brute force: every pair at every sample time, no pruning, with an
// independent position interpolation. The pruning must not change the minimum.
TEST(PlanValidation, MinimumSeparationMatchesBruteForce) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> coord(0.0, 400.0);
  std::uniform_real_distribution<double> step(1.0, 8.0);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<TimedPath> paths;
    for (int i = 0; i < 6; ++i) {
      TimedPath p;
      p.name = "u";
      double t = std::uniform_real_distribution<double>(0.0, 5.0)(rng);
      for (int k = 0; k < 8; ++k) {
        p.waypoints_m.emplace_back(coord(rng), coord(rng), 100.0 + 0.1 * coord(rng));
        p.times_s.push_back(t);
        t += step(rng);
      }
      paths.push_back(p);
    }
    PlanValidationOptions o;
    o.enforce_separation = false;  // only the minimum matters here
    const PlanValidationReport r = validate_plan(flat(), paths, world::SafetyLimits{}, o);

    auto at = [](const TimedPath& p, double t) {
      if (t <= p.times_s.front()) return p.waypoints_m.front();
      if (t >= p.times_s.back()) return p.waypoints_m.back();
      const auto it = std::upper_bound(p.times_s.begin(), p.times_s.end(), t);
      const std::size_t k = static_cast<std::size_t>(it - p.times_s.begin()) - 1;
      const double s = (t - p.times_s[k]) / (p.times_s[k + 1] - p.times_s[k]);
      return Vec3(p.waypoints_m[k] + s * (p.waypoints_m[k + 1] - p.waypoints_m[k]));
    };
    double t_lo = std::numeric_limits<double>::infinity();
    double t_hi = -t_lo;
    for (const TimedPath& p : paths) {
      t_lo = std::min(t_lo, p.times_s.front());
      t_hi = std::max(t_hi, p.times_s.back());
    }
    double brute = std::numeric_limits<double>::infinity();
    for (long m = 0;; ++m) {
      const double t = std::min(t_lo + m * o.separation_period_s, t_hi);
      for (std::size_t i = 0; i < paths.size(); ++i)
        for (std::size_t j = i + 1; j < paths.size(); ++j)
          brute = std::min(brute, (at(paths[i], t) - at(paths[j], t)).norm());
      if (t >= t_hi) break;
    }
    // Same samples, same arithmetic up to the interpolation's rounding.
    EXPECT_NEAR(r.min_separation_m, brute, 1e-9) << "trial " << trial;
  }
}

TEST(PlanValidation, RejectsMalformedInputNamingTheField) {
  try {
    validate_plan(flat(), {path("a", {Vec3(0, 0, 100), Vec3(1, 0, 100)}, {0.0, 0.0})},
                  world::SafetyLimits{});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "paths[0].times_s[1]");
  }
  PlanValidationOptions o;
  o.terrain_step_m = 7.0;
  EXPECT_THROW(validate_plan(flat(), {}, world::SafetyLimits{}, o), InputError);
  EXPECT_THROW(validate_plan(flat(), {path("a", {}, {})}, world::SafetyLimits{}), InputError);
  // A limit is checked where it is used, and the error names the scenario's field.
  world::SafetyLimits band_upside_down;
  band_upside_down.altitude = {500.0, 40.0};
  try {
    validate_plan(flat(), {path("a", {Vec3(0, 0, 100), Vec3(1, 0, 100)}, {0.0, 1.0})},
                  band_upside_down);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "altitude.min_m");
  }
}

}  // namespace
}  // namespace ridgeline::planning
