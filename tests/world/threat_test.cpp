#include "world/threat.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"

namespace ridgeline::world {
namespace {

Threat moving_threat() {
  Threat t;
  t.name = "hawk";
  t.centre_m = Vec3(100.0, 200.0, 300.0);
  t.velocity_m_s = Vec3(4.0, -3.0, 0.5);
  t.radius_m = 40.0;
  t.appear_s = 10.0;
  t.vanish_s = 70.0;
  return t;
}

TEST(Threat, CentreMovesUniformlyFromAppearance) {
  const Threat t = moving_threat();
  EXPECT_TRUE(t.centre_at(10.0).isApprox(Vec3(100.0, 200.0, 300.0), 1e-15));
  // eq. 13: c(t) = c0 + v_T (t − t_appear); at t = 30 s, 20 s after appearing.
  EXPECT_TRUE(t.centre_at(30.0).isApprox(Vec3(180.0, 140.0, 310.0), 1e-15));
  // Extrapolation before appearance is the same straight line.
  EXPECT_TRUE(t.centre_at(0.0).isApprox(Vec3(60.0, 230.0, 295.0), 1e-15));
}

TEST(Threat, ActiveOnlyInsideItsWindowEndsIncluded) {
  const Threat t = moving_threat();
  EXPECT_FALSE(t.active(9.999));
  EXPECT_TRUE(t.active(10.0));
  EXPECT_TRUE(t.active(40.0));
  EXPECT_TRUE(t.active(70.0));
  EXPECT_FALSE(t.active(70.001));
}

TEST(Threat, SurfaceDistanceIsSignedAndInfiniteWhenInactive) {
  const Threat t = moving_threat();
  const Vec3 c = t.centre_at(30.0);
  // 3-4-5 offset of 50 m from the centre: 10 m outside a 40 m sphere.
  EXPECT_NEAR(t.surface_distance(c + Vec3(30.0, 0.0, 40.0), 30.0), 10.0, 1e-12);
  EXPECT_NEAR(t.surface_distance(c + Vec3(0.0, 25.0, 0.0), 30.0), -15.0, 1e-12);
  EXPECT_NEAR(t.surface_distance(c, 30.0), -40.0, 1e-12);
  EXPECT_EQ(t.surface_distance(c, 5.0), std::numeric_limits<double>::infinity());
  EXPECT_EQ(t.surface_distance(t.centre_at(80.0), 80.0), std::numeric_limits<double>::infinity());
}

TEST(Threat, SensedWhenActiveAndSurfaceWithinRange) {
  const Threat t = moving_threat();
  const double range_m = 150.0;
  const Vec3 c = t.centre_at(20.0);
  // Surface at exactly the range (centre 190 m away) is sensed; 1 mm further is not.
  EXPECT_TRUE(t.sensed_by(c + Vec3(0.0, 190.0, 0.0), range_m, 20.0));
  EXPECT_FALSE(t.sensed_by(c + Vec3(0.0, 190.001, 0.0), range_m, 20.0));
  // Inside the sphere it is sensed too.
  EXPECT_TRUE(t.sensed_by(c + Vec3(5.0, 0.0, 0.0), range_m, 20.0));
  // Not before it appears nor after it vanishes, however close.
  EXPECT_FALSE(t.sensed_by(t.centre_at(5.0), range_m, 5.0));
  EXPECT_FALSE(t.sensed_by(t.centre_at(75.0), range_m, 75.0));
  // Zero range: only contact counts.
  EXPECT_TRUE(t.sensed_by(c + Vec3(40.0, 0.0, 0.0), 0.0, 20.0));
  EXPECT_FALSE(t.sensed_by(c + Vec3(40.5, 0.0, 0.0), 0.0, 20.0));
}

TEST(ClosestApproach, HeadOnPassMatchesHandComputation) {
  Threat t;
  t.centre_m = Vec3(0.0, 0.0, 100.0);
  t.radius_m = 30.0;
  t.appear_s = 0.0;
  t.vanish_s = 1000.0;
  // A UAV flying east at 10 m/s, 50 m north of the threat, from x = −1000 m at t = 0:
  // closest at t = 100 s, 50 m from the centre, 20 m clear of the surface.
  const auto ca =
      closest_approach(t, Vec3(-1000.0, 50.0, 100.0), Vec3(10.0, 0.0, 0.0), 0.0, 0.0, 1000.0);
  ASSERT_TRUE(ca.has_value());
  EXPECT_NEAR(ca->time_s, 100.0, 1e-9);
  EXPECT_NEAR(ca->centre_distance_m, 50.0, 1e-9);
  EXPECT_NEAR(ca->surface_distance_m, 20.0, 1e-9);
  EXPECT_TRUE(ca->point_m.isApprox(Vec3(0.0, 50.0, 100.0), 1e-12));

  // The same pass, but the threat vanishes at t = 60 s: the closest moment in its life is
  // its last, when the UAV is still 400 m west.
  t.vanish_s = 60.0;
  const auto clipped =
      closest_approach(t, Vec3(-1000.0, 50.0, 100.0), Vec3(10.0, 0.0, 0.0), 0.0, 0.0, 1000.0);
  ASSERT_TRUE(clipped.has_value());
  EXPECT_NEAR(clipped->time_s, 60.0, 1e-12);
  EXPECT_NEAR(clipped->centre_distance_m, std::hypot(400.0, 50.0), 1e-9);

  // A window that ends before the threat appears has no approach at all.
  t.appear_s = 500.0;
  t.vanish_s = 600.0;
  EXPECT_FALSE(closest_approach(t, Vec3::Zero(), Vec3::UnitX(), 0.0, 0.0, 400.0).has_value());

  // No relative motion: every time is closest; the window's start is reported.
  Threat still;
  still.radius_m = 5.0;
  still.appear_s = 3.0;
  const auto same = closest_approach(still, Vec3(10.0, 0.0, 0.0), Vec3::Zero(), 0.0, 0.0, 50.0);
  ASSERT_TRUE(same.has_value());
  EXPECT_EQ(same->time_s, 3.0);
  EXPECT_NEAR(same->surface_distance_m, 5.0, 1e-12);
}

TEST(ClosestApproach, AgreesWithBruteForceSampling) {
  Rng rng(2024);
  for (int trial = 0; trial < 200; ++trial) {
    Threat t;
    t.centre_m = Vec3(rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(0, 300));
    t.velocity_m_s = Vec3(rng.uniform(-8, 8), rng.uniform(-8, 8), rng.uniform(-1, 1));
    t.radius_m = rng.uniform(30, 60);
    t.appear_s = rng.uniform(0, 50);
    t.vanish_s = t.appear_s + rng.uniform(10, 200);
    const Vec3 p_ref(rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(0, 300));
    const Vec3 v(rng.uniform(-15, 15), rng.uniform(-15, 15), rng.uniform(-3, 3));
    const double t_ref = rng.uniform(0, 100);
    const double t_begin = rng.uniform(0, 60), t_end = t_begin + rng.uniform(20, 200);

    const auto ca = closest_approach(t, p_ref, v, t_ref, t_begin, t_end);
    const double lo = std::max(t_begin, t.appear_s), hi = std::min(t_end, t.vanish_s);
    ASSERT_EQ(ca.has_value(), lo <= hi) << "trial " << trial;
    if (!ca) continue;

    constexpr int kSteps = 20000;
    const double h = (hi - lo) / kSteps;
    double brute = std::numeric_limits<double>::infinity();
    for (int i = 0; i <= kSteps; ++i) {
      const double time = lo + i * h;
      brute = std::min(brute, (p_ref + v * (time - t_ref) - t.centre_at(time)).norm());
    }
    // The analytic minimum is exact over the continuous window, so the grid can only be
    // larger; the centre distance changes at most |v − v_T| per second, so the grid's minimum
    // exceeds it by at most |v − v_T|·h/2 (plus rounding).
    const double lipschitz = (v - t.velocity_m_s).norm();
    EXPECT_GE(brute, ca->centre_distance_m - 1e-9) << "trial " << trial;
    EXPECT_LE(brute, ca->centre_distance_m + 0.5 * lipschitz * h + 1e-9) << "trial " << trial;
    EXPECT_NEAR(ca->surface_distance_m, ca->centre_distance_m - t.radius_m, 1e-12);
    EXPECT_GE(ca->time_s, lo);
    EXPECT_LE(ca->time_s, hi);
  }
}

std::string error_field(const Threat& t, std::string_view prefix) {
  try {
    validate(t, prefix);
  } catch (const InputError& e) {
    return e.field();
  }
  return "<no error>";
}

TEST(ThreatValidation, ErrorsNameTheField) {
  const double nan = std::nan("");
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    std::function<void(Threat&)> mutate;
    std::string field;
  };
  const std::vector<Case> cases = {
      {[&](Threat& t) { t.centre_m.z() = nan; }, "threats[2].centre_m"},
      {[&](Threat& t) { t.velocity_m_s.x() = inf; }, "threats[2].velocity_m_s"},
      {[&](Threat& t) { t.radius_m = 0.0; }, "threats[2].radius_m"},
      {[&](Threat& t) { t.radius_m = -3.0; }, "threats[2].radius_m"},
      {[&](Threat& t) { t.radius_m = nan; }, "threats[2].radius_m"},
      {[&](Threat& t) { t.appear_s = -inf; }, "threats[2].appear_s"},
      {[&](Threat& t) { t.vanish_s = inf; }, "threats[2].vanish_s"},
      {[&](Threat& t) { t.vanish_s = t.appear_s; }, "threats[2].vanish_s"},
      {[&](Threat& t) { t.vanish_s = 5.0; }, "threats[2].vanish_s"},
  };
  for (const Case& k : cases) {
    Threat t = moving_threat();
    k.mutate(t);
    EXPECT_EQ(error_field(t, "threats[2]"), k.field);
  }
  EXPECT_EQ(error_field(moving_threat(), "threats[2]"), "<no error>");
  Threat bad = moving_threat();
  bad.radius_m = -3.0;
  try {
    validate(bad, "threats[0]");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "threats[0].radius_m: must be > 0, got -3");
  }
}

}  // namespace
}  // namespace ridgeline::world
