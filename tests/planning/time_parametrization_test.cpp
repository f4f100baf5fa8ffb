#include "planning/time_parametrization.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/random.hpp"

namespace ridgeline::planning {
namespace {

// The default vehicle of DESIGN §7: v0 = 10 m/s, Δv = 5 m/s, R_min = 10 m, w_max = 3 m/s,
// θ_max = 30°.
vehicle::VehicleParams default_vehicle() { return vehicle::VehicleParams{}; }

bool has_violation(const TimeParametrizationResult& r, LimitKind kind, double t_s) {
  // Sample times are exact phase times; 1e-9 s absorbs the rounding of the time sums.
  return std::any_of(r.violations.begin(), r.violations.end(), [&](const LimitViolation& v) {
    return v.kind == kind && t_s >= v.t_begin_s - 1e-9 && t_s <= v.t_end_s + 1e-9;
  });
}

int count_kind(const TimeParametrizationResult& r, LimitKind kind) {
  return static_cast<int>(std::count_if(r.violations.begin(), r.violations.end(),
                                        [&](const LimitViolation& v) { return v.kind == kind; }));
}

// Every sample respects every limit of eq. 2–3 and the acceleration limit, or a violation of
// that kind is reported for the stretch containing it. Tolerances: the limits are met by
// construction up to rounding (values ~10, so 1e-9 relative is ~1000 ulps).
void expect_limits_or_reported(const TimeParametrizationResult& r, const vehicle::VehicleParams& vp,
                               const TimeParametrizationOptions& o) {
  ASSERT_TRUE(r.reference.has_value());
  const auto& ts = r.sample_times_s;
  const auto& pts = r.samples;
  ASSERT_EQ(ts.size(), pts.size());
  ASSERT_GE(ts.size(), 2u);
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const auto& q = pts[k];
    const double t = ts[k];
    EXPECT_GE(q.speed_m_s, vp.min_speed_m_s() - 1e-9) << "t=" << t;
    EXPECT_LE(q.speed_m_s, vp.max_speed_m_s() + 1e-9) << "t=" << t;
    if (std::abs(q.turn_rate_rad_s) > vp.max_turn_rate_rad_s(q.speed_m_s) * (1.0 + 1e-9)) {
      EXPECT_TRUE(has_violation(r, LimitKind::kTurnRadius, t)) << "turn rate at t=" << t;
    }
    if (std::abs(q.climb_rate_m_s) > vp.max_climb_rate_m_s + 1e-9) {
      EXPECT_TRUE(has_violation(r, LimitKind::kClimbRate, t)) << "climb rate at t=" << t;
    }
    if (std::atan2(std::abs(q.climb_rate_m_s), q.speed_m_s) > vp.max_pitch_rad + 1e-9) {
      EXPECT_TRUE(has_violation(r, LimitKind::kPitch, t)) << "pitch at t=" << t;
    }
    if (k > 0) {
      const double dt = ts[k] - ts[k - 1];
      EXPECT_GT(dt, 0.0);
      EXPECT_LE(dt, o.control_period_s * (1.0 + 1e-9));
      EXPECT_LE(std::abs(q.speed_m_s - pts[k - 1].speed_m_s), o.max_accel_m_s2 * dt + 1e-9)
          << "acceleration at t=" << t;
    }
  }
}

// Trapezoidal integration of the sampled velocity (v cos ψ, v sin ψ, ż) from the first sample.
// Horizontal velocity is continuous along the path (tangent arcs, rate-limited speed), so the
// trapezoid's horizontal error per step is ≤ Δt³/12·|v̈| on smooth stretches and ≤ Δt²/8·|Δa|
// across a jump of acceleration (an arc entry). The height z(s) is piecewise linear: at a grade
// change ż jumps, and a step containing the jump is off by ≤ ½Δt·|Δż|; that allowance is
// returned per step so the checks can add it.
struct IntegrationError {
  double max_horizontal_step_m = 0.0;  ///< max per-step horizontal error
  double max_vertical_excess_m = 0.0;  ///< max per-step vertical error minus ½Δt·|Δż|
  double final_horizontal_m = 0.0;     ///< accumulated horizontal error at the last sample
};
IntegrationError integrate_velocity(const TimeParametrizationResult& r) {
  auto velocity = [](const mpc::ReferencePoint& q) {
    return Vec3(q.speed_m_s * std::cos(q.heading_rad), q.speed_m_s * std::sin(q.heading_rad),
                q.climb_rate_m_s);
  };
  IntegrationError e;
  Vec2 p = r.samples.front().position_m.head<2>();
  for (std::size_t k = 1; k < r.samples.size(); ++k) {
    const auto& q0 = r.samples[k - 1];
    const auto& q1 = r.samples[k];
    const double dt = r.sample_times_s[k] - r.sample_times_s[k - 1];
    const Vec3 step = 0.5 * dt * (velocity(q0) + velocity(q1));
    const Vec3 true_step = q1.position_m - q0.position_m;
    e.max_horizontal_step_m =
        std::max(e.max_horizontal_step_m, (step - true_step).head<2>().norm());
    const double vertical_allowance = 0.5 * dt * std::abs(q1.climb_rate_m_s - q0.climb_rate_m_s);
    e.max_vertical_excess_m =
        std::max(e.max_vertical_excess_m, std::abs(step.z() - true_step.z()) - vertical_allowance);
    p += step.head<2>();
  }
  e.final_horizontal_m = (p - r.samples.back().position_m.head<2>()).norm();
  return e;
}

TEST(TimeParametrization, StraightLineAtCruiseGivesExactPositions) {
  const auto vp = default_vehicle();
  TimeParametrizationOptions o;
  o.start_time_s = 5.0;
  // Horizontal 1000 m, climbing 100 m: grade 0.1, w = 1 m/s at 10 m/s (within w_max).
  const Vec3 a(10.0, -20.0, 100.0);
  const Vec3 b(10.0 + 600.0, -20.0 + 800.0, 200.0);
  const auto r = time_parametrize({a, b}, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kOk) << r.message;
  ASSERT_TRUE(r.violations.empty());
  EXPECT_NEAR(r.duration_s, 100.0, 1e-9);  // 1000 m / 10 m/s; 1e-9: rounding of one division
  EXPECT_EQ(r.samples.size(), 5001u);
  EXPECT_NEAR(r.horizontal_length_m, 1000.0, 1e-9);
  EXPECT_NEAR(r.path_length_m, std::hypot(1000.0, 100.0), 1e-9);
  const Vec3 dir = (b - a) / 1000.0;  // per horizontal metre
  for (std::size_t k = 0; k < r.samples.size(); ++k) {
    const double t = r.sample_times_s[k];
    // Grid times t_k = t0 + kΔt exactly; positions are a + v·(t − t0)·dir up to rounding of
    // sums of ~1000 m (1e-9 m ≈ 10⁴ ulps, far below anything physical).
    EXPECT_NEAR(t, 5.0 + 0.02 * static_cast<double>(k), 1e-9);
    const auto& q = r.samples[k];
    EXPECT_LT((q.position_m - (a + 10.0 * (t - 5.0) * dir)).norm(), 1e-9) << "k=" << k;
    EXPECT_NEAR(q.speed_m_s, 10.0, 1e-12);
    EXPECT_NEAR(q.heading_rad, std::atan2(800.0, 600.0), 1e-12);
    EXPECT_EQ(q.turn_rate_rad_s, 0.0);
    EXPECT_NEAR(q.climb_rate_m_s, 1.0, 1e-12);
  }
  // The SampledReference interpolates the same line between samples.
  const auto mid = r.reference->at(5.0 + 33.333);
  EXPECT_LT((mid.position_m - (a + 333.33 * dir)).norm(), 1e-9);
}

TEST(TimeParametrization, SquareGetsRoundedCornersWithinTurnLimit) {
  const auto vp = default_vehicle();
  TimeParametrizationOptions o;  // R* = 1.2·R_min = 12 m
  const double z = 150.0;
  const std::vector<Vec3> square = {{0, 0, z}, {200, 0, z}, {200, 200, z}, {0, 200, z}, {0, 0, z}};
  const auto r = time_parametrize(square, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kOk) << r.message;
  EXPECT_EQ(r.corners_rounded, 3);
  EXPECT_EQ(r.corners_tightened, 0);
  EXPECT_EQ(r.reversal_loops, 0);
  EXPECT_NEAR(r.min_turn_radius_m, 12.0, 1e-12);
  EXPECT_NEAR(r.max_curvature_1_m, 1.0 / 12.0, 1e-12);
  // Each 90° corner replaces 2R of straight line by a quarter circle Rπ/2.
  const double length = 800.0 - 3.0 * 12.0 * (2.0 - 0.5 * kPi);
  EXPECT_NEAR(r.horizontal_length_m, length, 1e-9);
  EXPECT_NEAR(r.duration_s, length / 10.0, 1e-9);  // no limit requires slowing
  EXPECT_NEAR(r.max_turn_rate_rad_s, 10.0 / 12.0, 1e-12);
  // The vertex is R(√2 − 1) from the arc midpoint that stands for it.
  EXPECT_NEAR(r.max_waypoint_offset_m, 12.0 * (std::sqrt(2.0) - 1.0), 1e-9);
  expect_limits_or_reported(r, vp, o);

  // Independent geometry: the arc at corner (200, 0) is the circle of radius 12 tangent to
  // y = 0 and x = 200, centre (188, 12); every turning sample near it lies on that circle.
  const Vec2 centre(188.0, 12.0);
  int on_first_arc = 0;
  for (const auto& q : r.samples) {
    EXPECT_LE(std::abs(q.turn_rate_rad_s), q.speed_m_s / vp.min_turn_radius_m + 1e-12);
    if (q.turn_rate_rad_s != 0.0 && q.position_m.x() > 150.0 && q.position_m.y() < 50.0) {
      ++on_first_arc;
      EXPECT_NEAR((q.position_m.head<2>() - centre).norm(), 12.0, 1e-9);
      EXPECT_GT(q.turn_rate_rad_s, 0.0);  // a left turn
    }
  }
  // A quarter circle of 18.85 m at 10 m/s lasts 1.885 s: 94 or 95 samples at 50 Hz.
  EXPECT_GE(on_first_arc, 94);
  EXPECT_LE(on_first_arc, 95);
  EXPECT_NEAR(r.samples.back().heading_rad, 1.5 * kPi, 1e-9);  // unwrapped: three left turns
  EXPECT_LT((r.samples.back().position_m - square.back()).norm(), 1e-9);

  // A lateral-acceleration limit a_lat = 4 m/s² slows each 12 m arc to √(4·12) = 6.93 m/s.
  TimeParametrizationOptions lat = o;
  lat.max_lateral_accel_m_s2 = 4.0;
  const auto slowed = time_parametrize(square, vp, lat);
  ASSERT_EQ(slowed.status, TimeParametrizationStatus::kOk) << slowed.message;
  EXPECT_EQ(slowed.corners_slowed, 3);
  EXPECT_NEAR(slowed.min_speed_m_s, std::sqrt(48.0), 1e-9);
  expect_limits_or_reported(slowed, vp, lat);
  for (const auto& q : slowed.samples) {
    // a_lat = v·|ψ̇| = v²/R; 1e-9 relative: rounding.
    EXPECT_LE(q.speed_m_s * std::abs(q.turn_rate_rad_s), 4.0 * (1.0 + 1e-9));
  }

  o.corner_rounding = CornerRounding::kWidest;
  const auto wide = time_parametrize(square, vp, o);
  ASSERT_EQ(wide.status, TimeParametrizationStatus::kOk) << wide.message;
  // Half of an interior 200 m side is available: R = 100 m at every corner.
  EXPECT_NEAR(wide.min_turn_radius_m, 100.0, 1e-9);
  EXPECT_NEAR(wide.max_turn_rate_rad_s, 0.1, 1e-12);
  expect_limits_or_reported(wide, vp, o);
}

TEST(TimeParametrization, SteepClimbIsSlowedToClimbLimit) {
  const auto vp = default_vehicle();
  TimeParametrizationOptions o;
  // Grade 0.5 (pitch 26.6° < 30°): at 10 m/s the climb rate would be 5 m/s > w_max = 3, so the
  // climb is flown at w_max / 0.5 = 6 m/s (≥ v0 − Δv = 5).
  const std::vector<Vec3> path = {{0, 0, 100}, {300, 0, 100}, {400, 0, 150}, {700, 0, 150}};
  const auto r = time_parametrize(path, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kOk) << r.message;
  EXPECT_NEAR(r.max_climb_rate_m_s, 3.0, 1e-9);
  EXPECT_NEAR(r.max_pitch_rad, std::atan(0.5), 1e-12);
  EXPECT_NEAR(r.min_speed_m_s, 6.0, 1e-9);
  expect_limits_or_reported(r, vp, o);
  for (const auto& q : r.samples) {
    EXPECT_LE(std::abs(q.climb_rate_m_s), vp.max_climb_rate_m_s + 1e-9);
    if (q.position_m.x() > 300.0 && q.position_m.x() < 400.0) {
      EXPECT_NEAR(q.speed_m_s, 6.0, 1e-9);
    }
  }
  // Timing by hand: flat at 10 except the 1 m/s² ramps 10 → 6 (32 m, 4 s) before and
  // 6 → 10 (32 m, 4 s) after the 100 m climb at 6 m/s.
  const double expected = (300.0 - 32.0) / 10.0 + 4.0 + 100.0 / 6.0 + 4.0 + (300.0 - 32.0) / 10.0;
  EXPECT_NEAR(r.duration_s, expected, 1e-9);
  EXPECT_NEAR(r.waypoint_times_s[2] - r.waypoint_times_s[1], 100.0 / 6.0, 1e-9);
}

// A climb at 0.97 tan θ_max that turns 60° at every waypoint (segments 60 m, R = 12 m): the
// heights are spread over each stretch between waypoints, so every corner adds only the length
// its arc cuts, R·(tan 30° − π/6) = 0.64 m of 60 m, and the flown grade stays within the pitch
// limit. Linear heights on the arcs alone (the former rule) steepened each arc by
// 2·tan 30°/(π/3) = 1.10, to 1.07 tan θ_max: a pitch violation at every corner.
TEST(TimeParametrization, CornersOfAClimbAtThePitchLimitKeepItFlyable) {
  const auto vp = default_vehicle();
  const double grade = 0.97 * std::tan(vp.max_pitch_rad);
  const double len_m = 60.0;
  std::vector<Vec3> w = {{0, 0, 100}};
  for (int k = 0; k < 6; ++k) {
    const double heading = k * kPi / 3.0;  // 60° left at every waypoint
    w.push_back(w.back() +
                Vec3(len_m * std::cos(heading), len_m * std::sin(heading), grade * len_m));
  }
  const auto r = time_parametrize(w, vp);
  ASSERT_TRUE(r.reference.has_value()) << r.message;
  EXPECT_EQ(r.corners_rounded, 5);
  EXPECT_EQ(count_kind(r, LimitKind::kPitch), 0);
  EXPECT_EQ(r.status, TimeParametrizationStatus::kOk);
  // Every stretch is 60 m less two cuts of 0.64 m: grade × 60/58.7 (1e-6: rounding).
  const double cut_m = 1.2 * vp.min_turn_radius_m * (std::tan(kPi / 6.0) - kPi / 6.0);
  EXPECT_NEAR(std::tan(r.max_pitch_rad), grade * len_m / (len_m - 2.0 * cut_m), 1e-6);
  EXPECT_LT(r.max_pitch_rad, vp.max_pitch_rad);
  // Each waypoint's height is met where the reference passes it (its arc's midpoint): the
  // sample nearest that time is within half a period, 0.01 s, at |ż| ≤ w_max = 3 m/s: 0.03 m.
  ASSERT_EQ(r.waypoint_times_s.size(), w.size());
  for (std::size_t k = 0; k < w.size(); ++k) {
    const auto nearest =
        std::min_element(r.sample_times_s.begin(), r.sample_times_s.end(), [&](double a, double b) {
          return std::abs(a - r.waypoint_times_s[k]) < std::abs(b - r.waypoint_times_s[k]);
        });
    const std::size_t i = static_cast<std::size_t>(nearest - r.sample_times_s.begin());
    EXPECT_NEAR(r.samples[i].position_m.z(), w[k].z(), 0.03) << "waypoint " << k;
  }
}

TEST(TimeParametrization, ImpossibleClimbIsReportedNotHidden) {
  auto vp = default_vehicle();
  TimeParametrizationOptions o;
  // Grade 0.7: pitch 35° > θ_max = 30°, and even v0 − Δv = 5 m/s climbs at 3.5 m/s > 3.
  const std::vector<Vec3> path = {{0, 0, 100}, {200, 0, 100}, {300, 0, 170}, {500, 0, 170}};
  const auto r = time_parametrize(path, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kLimitViolated);
  ASSERT_TRUE(r.reference.has_value());  // still flyable as a best effort
  ASSERT_EQ(count_kind(r, LimitKind::kPitch), 1);
  ASSERT_EQ(count_kind(r, LimitKind::kClimbRate), 1);
  for (const auto& v : r.violations) {
    EXPECT_EQ(v.waypoint, 1);                                 // the segment 1 → 2
    EXPECT_NEAR(v.t_end_s - v.t_begin_s, 100.0 / 5.0, 1e-9);  // flown at v0 − Δv
    if (v.kind == LimitKind::kPitch) {
      EXPECT_NEAR(v.value, std::atan(0.7), 1e-12);
    }
    if (v.kind == LimitKind::kClimbRate) {
      EXPECT_NEAR(v.value, 3.5, 1e-12);
    }
  }
  EXPECT_NEAR(r.max_pitch_rad, std::atan(0.7), 1e-12);
  EXPECT_NEAR(r.max_climb_rate_m_s, 3.5, 1e-9);
  expect_limits_or_reported(r, vp, o);

  // With θ_max = 40° only the climb rate is impossible.
  vp.max_pitch_rad = deg_to_rad(40.0);
  const auto r2 = time_parametrize(path, vp, o);
  ASSERT_EQ(r2.status, TimeParametrizationStatus::kLimitViolated);
  EXPECT_EQ(count_kind(r2, LimitKind::kPitch), 0);
  EXPECT_EQ(count_kind(r2, LimitKind::kClimbRate), 1);
}

TEST(TimeParametrization, IntegratingSampledVelocityReproducesPositions) {
  const auto vp = default_vehicle();
  TimeParametrizationOptions o;
  const std::vector<Vec3> path = {{0, 0, 100},     {300, 0, 120},   {350, 250, 180},
                                  {100, 400, 160}, {120, 700, 160}, {600, 650, 100}};
  const auto r = time_parametrize(path, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kOk) << r.message;
  expect_limits_or_reported(r, vp, o);
  const auto e = integrate_velocity(r);
  // Horizontal, per step: smooth stretches |v̈| = v³/R² ≤ 15³/12² ≈ 23 m/s³ → Δt³/12·23 =
  // 1.6e-5 m; an arc entry at 10 m/s jumps the acceleration by v²/R = 8.3 m/s² → Δt²/8·8.3 =
  // 4.2e-4 m. Bound 5e-4 m. Accumulated over the ≈ 2 km path: the arcs' systematic chord
  // shortening (relative (ωΔt)²/24 ≈ 1.2e-5 of ≈ 80 m of arcs) plus a few entry steps: < 1 cm.
  // Vertical: the height is linear on each stretch, so beyond the ½Δt·|Δż| allowance of a
  // grade change the trapezoid is exact up to the speed ramps (Δt²/8·a·|g| ≈ 5e-5 m): 1e-4 m.
  EXPECT_LT(e.max_horizontal_step_m, 5e-4);
  EXPECT_LT(e.final_horizontal_m, 1e-2);
  EXPECT_LT(e.max_vertical_excess_m, 1e-4);
  RecordProperty("max_horizontal_step_error_m", std::to_string(e.max_horizontal_step_m));
  RecordProperty("final_horizontal_error_m", std::to_string(e.final_horizontal_m));

  // The heading advances by the turn rate: trapezoid on ψ̇ is exact where ψ̇ is constant and
  // off by ≤ ½·|Δψ̇|·Δt at an arc entry (10/12 rad/s → 8.3e-3 rad).
  for (std::size_t k = 1; k < r.samples.size(); ++k) {
    const double dt = r.sample_times_s[k] - r.sample_times_s[k - 1];
    const double dpsi = r.samples[k].heading_rad - r.samples[k - 1].heading_rad;
    const double avg = 0.5 * (r.samples[k].turn_rate_rad_s + r.samples[k - 1].turn_rate_rad_s);
    EXPECT_NEAR(dpsi, avg * dt, 8.4e-3) << "k=" << k;
  }
}

TEST(TimeParametrization, RandomPolylinesRespectEveryLimitOrReportIt) {
  Rng rng(20261122);
  const auto vp = default_vehicle();
  TimeParametrizationOptions o;
  int with_violations = 0;
  int ok = 0;
  int loops = 0;
  int duplicates = 0;
  double worst_step_m = 0.0;
  for (int trial = 0; trial < 150; ++trial) {
    const int n = 2 + static_cast<int>(rng.uniform(0.0, 10.0));
    std::vector<Vec3> w;
    Vec3 p(rng.uniform(0.0, 1000.0), rng.uniform(0.0, 1000.0), rng.uniform(50.0, 300.0));
    w.push_back(p);
    for (int i = 1; i < n; ++i) {
      const double u = rng.uniform();
      if (u < 0.08) {
        w.push_back(w.back());  // exact duplicate
      } else if (u < 0.15 && w.size() >= 2) {
        w.push_back(w[w.size() - 2]);  // reversal
      } else {
        const double len = rng.uniform(5.0, 300.0);
        const double ang = rng.uniform(-kPi, kPi);
        // Mostly flyable grades (|g| ≤ 0.45 < tan 30°), one segment in five up to 0.8.
        const double max_grade = rng.uniform() < 0.2 ? 0.8 : 0.45;
        const double dz = rng.uniform(-max_grade, max_grade) * len;
        w.push_back(w.back() + Vec3(len * std::cos(ang), len * std::sin(ang), dz));
      }
    }
    if (rng.uniform() < 0.3)
      o.corner_rounding = CornerRounding::kWidest;
    else
      o.corner_rounding = CornerRounding::kTightest;
    const auto r = time_parametrize(w, vp, o);
    if (r.status == TimeParametrizationStatus::kInvalidInput) {
      // Only a path with no horizontal extent is rejected.
      EXPECT_NE(r.message.find("waypoints_m"), std::string::npos) << r.message;
      continue;
    }
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_EQ(r.status == TimeParametrizationStatus::kOk, r.violations.empty());
    expect_limits_or_reported(r, vp, o);
    EXPECT_LT((r.samples.back().position_m - w.back()).norm(), 1e-6);  // ends at the last waypoint
    const auto e = integrate_velocity(r);
    worst_step_m = std::max(worst_step_m, e.max_horizontal_step_m);
    // Arcs shrunk below k_s·R_min raise |v̈| = v³/R² and the entry jump v²/R: the step bound
    // scales with 1/R, so only paths without tightened corners are bounded here. Loops and
    // back-to-back opposite arcs reverse the turn (|Δa| = 2v²/R = 16.7 m/s² at 10 m/s, R = 12 m):
    // Δt²/8·16.7 = 8.3e-4 m, plus 1.6e-5 m of smooth-arc error → 9e-4 m.
    if (r.corners_tightened == 0) {
      EXPECT_LT(e.max_horizontal_step_m, 9e-4);
    }
    EXPECT_LT(e.max_vertical_excess_m, 1e-4);
    with_violations += r.violations.empty() ? 0 : 1;
    ok += r.status == TimeParametrizationStatus::kOk ? 1 : 0;
    loops += r.reversal_loops;
    duplicates += r.duplicates_removed;
  }
  // The generator must exercise every branch.
  EXPECT_GT(with_violations, 0);
  EXPECT_GT(ok, 0);
  EXPECT_GT(loops, 0);
  EXPECT_GT(duplicates, 0);
  RecordProperty("with_violations", with_violations);
  RecordProperty("ok", ok);
  RecordProperty("loops", loops);
  RecordProperty("worst_horizontal_step_error_m", std::to_string(worst_step_m));
}

TEST(TimeParametrization, DuplicatePointsAreMergedAndReported) {
  const auto vp = default_vehicle();
  const std::vector<Vec3> clean = {{0, 0, 100}, {300, 0, 100}, {300, 300, 100}};
  const std::vector<Vec3> dup = {{0, 0, 100},        {0, 0, 100},     {300, 0, 100},
                                 {300.0, 1e-4, 100}, {300, 300, 100}, {300, 300, 100}};
  const auto a = time_parametrize(clean, vp);
  const auto b = time_parametrize(dup, vp);
  ASSERT_EQ(b.status, TimeParametrizationStatus::kOk) << b.message;
  EXPECT_EQ(b.duplicates_removed, 3);
  EXPECT_NEAR(b.duration_s, a.duration_s, 1e-9);
  ASSERT_EQ(b.waypoint_times_s.size(), 6u);
  EXPECT_EQ(b.waypoint_times_s[0], b.waypoint_times_s[1]);
  EXPECT_EQ(b.waypoint_times_s[2], b.waypoint_times_s[3]);
  EXPECT_EQ(b.waypoint_times_s[4], b.waypoint_times_s[5]);

  // Same horizontal point at another height: a vertical segment, which no speed can fly.
  const std::vector<Vec3> vertical = {{0, 0, 100}, {300, 0, 100}, {300, 0, 140}, {600, 0, 140}};
  const auto c = time_parametrize(vertical, vp);
  ASSERT_EQ(c.status, TimeParametrizationStatus::kLimitViolated);
  ASSERT_GE(c.violations.size(), 1u);
  EXPECT_EQ(c.violations.front().kind, LimitKind::kPitch);
  EXPECT_EQ(c.violations.front().waypoint, 1);
  EXPECT_NEAR(c.violations.front().value, 0.5 * kPi, 1e-12);

  // All points on one vertical line: nothing to fly.
  const auto d = time_parametrize({{0, 0, 100}, {0, 0, 100}, {0, 0, 200}}, vp);
  EXPECT_EQ(d.status, TimeParametrizationStatus::kInvalidInput);
  EXPECT_NE(d.message.find("waypoints_m"), std::string::npos);
}

TEST(TimeParametrization, ReversalIsFlownAsLoopThroughVertex) {
  const auto vp = default_vehicle();
  TimeParametrizationOptions o;
  const std::vector<Vec3> path = {{0, 0, 100}, {200, 0, 100}, {0, 0, 100}};
  const auto r = time_parametrize(path, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kOk) << r.message;
  EXPECT_EQ(r.reversal_loops, 1);
  EXPECT_EQ(r.corners_rounded, 0);
  EXPECT_NEAR(r.min_turn_radius_m, 12.0, 1e-12);
  // Loop of radius R: arcs of 60°, 300°, 60° (7πR/3 long) whose far point is (1 + √3)R past V.
  EXPECT_NEAR(r.horizontal_length_m, 400.0 + 7.0 * kPi * 12.0 / 3.0, 1e-9);
  EXPECT_NEAR(r.max_waypoint_offset_m, (1.0 + std::sqrt(3.0)) * 12.0, 1e-9);
  expect_limits_or_reported(r, vp, o);
  EXPECT_LT((r.samples.back().position_m - path.back()).norm(), 1e-9);
  EXPECT_NEAR(wrap_angle(r.samples.back().heading_rad - kPi), 0.0, 1e-9);
  const auto e = integrate_velocity(r);
  EXPECT_LT(e.max_horizontal_step_m, 5e-4);  // bound of IntegratingSampledVelocity…
}

TEST(TimeParametrization, CornerWithoutRoomIsReportedAsTurnRadiusViolation) {
  const auto vp = default_vehicle();
  TimeParametrizationOptions o;
  // 90° corners between 10 m segments: half a segment (5 m) fits an arc of radius 5 m only.
  const std::vector<Vec3> zigzag = {{0, 0, 100},   {10, 0, 100},  {10, 10, 100},
                                    {20, 10, 100}, {20, 20, 100}, {30, 20, 100}};
  const auto r = time_parametrize(zigzag, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kLimitViolated);
  EXPECT_EQ(count_kind(r, LimitKind::kTurnRadius), 4);
  EXPECT_EQ(r.corners_tightened, 4);
  EXPECT_NEAR(r.min_turn_radius_m, 5.0, 1e-12);
  for (const auto& v : r.violations) EXPECT_NEAR(v.value, 5.0, 1e-12);
  EXPECT_NEAR(r.max_turn_rate_rad_s, 10.0 / 5.0, 1e-12);  // v/R, honestly above v/R_min
  expect_limits_or_reported(r, vp, o);
}

TEST(TimeParametrization, TimedModePassesWaypointsAtPlannedTimes) {
  const auto vp = default_vehicle();
  TimeParametrizationOptions o;
  // Legs of 300 m (between the vertices) planned at 8, 11, 9 and 12 m/s: in the 5–15 band,
  // and the speed changes are within reach of the 1 m/s² ramps.
  const std::vector<Vec3> path = {
      {0, 0, 100}, {300, 0, 100}, {300, 300, 100}, {600, 300, 100}, {600, 600, 100}};
  std::vector<double> times = {10.0};
  for (double v : {8.0, 11.0, 9.0, 12.0}) times.push_back(times.back() + 300.0 / v);
  const auto r = time_parametrize_timed(path, times, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kOk) << r.message;
  expect_limits_or_reported(r, vp, o);
  EXPECT_NEAR(r.sample_times_s.front(), 10.0, 1e-12);
  // The iteration stops once every waypoint is within 1e-6 s; 1e-3 s (1 cm at 10 m/s) allows
  // for legs whose ramps limit the catch-up.
  EXPECT_LT(r.max_time_deviation_s, 1e-3);
  for (std::size_t k = 0; k < times.size(); ++k) {
    EXPECT_NEAR(r.waypoint_times_s[k], times[k], 1e-3);
  }
  RecordProperty("timing_iterations", r.timing_iterations);

  // Planned at 8, 12, 6, 14 m/s: the last leg cannot be reached in time after the ramp up from
  // 6 m/s (≈ 9 s of ramp to 15 m/s), so the result reports the deviation it could not remove.
  std::vector<double> hard = {10.0};
  for (double v : {8.0, 12.0, 6.0, 14.0}) hard.push_back(hard.back() + 300.0 / v);
  const auto missed = time_parametrize_timed(path, hard, vp, o);
  ASSERT_EQ(missed.status, TimeParametrizationStatus::kTimingMissed) << missed.message;
  double dev = 0.0;
  for (std::size_t k = 0; k < hard.size(); ++k) {
    dev = std::max(dev, std::abs(missed.waypoint_times_s[k] - hard[k]));
  }
  EXPECT_EQ(missed.max_time_deviation_s, dev);
  EXPECT_GT(dev, o.time_tolerance_s);
  expect_limits_or_reported(missed, vp, o);

  // A leg that needs 20 m/s is flown at v0 + Δv = 15 m/s and reported late: 1000 m at 15 m/s
  // takes 66.67 s instead of 50 s.
  const auto late = time_parametrize_timed({{0, 0, 100}, {1000, 0, 100}}, {0.0, 50.0}, vp, o);
  ASSERT_EQ(late.status, TimeParametrizationStatus::kTimingMissed) << late.message;
  EXPECT_NEAR(late.max_time_deviation_s, 1000.0 / 15.0 - 50.0, 1e-9);
  EXPECT_NEAR(late.max_speed_m_s, 15.0, 1e-12);
}

TEST(TimeParametrization, TimedModeFollowsIrregularOptimizerGrid) {
  // 100 waypoints 15–35 m apart, each leg planned at its own speed in 8–12 m/s: alternating
  // speed changes of up to 4 m/s every 2–3 s, faster than 1 m/s² ramps can follow leg by leg.
  // The cumulative time can still be matched to within the default 0.5 s tolerance.
  const auto vp = default_vehicle();
  Rng rng(7);
  std::vector<Vec3> w = {{0, 0, 100}};
  std::vector<double> t = {0.0};
  for (int i = 1; i < 100; ++i) {
    const double ang = 0.8 + rng.uniform(-0.6, 0.6);
    const double len = rng.uniform(15.0, 35.0);
    w.push_back(w.back() +
                Vec3(len * std::cos(ang), len * std::sin(ang), rng.uniform(-0.2, 0.2) * len));
    t.push_back(t.back() + len / rng.uniform(8.0, 12.0));
  }
  TimeParametrizationOptions o;
  const auto r = time_parametrize_timed(w, t, vp, o);
  ASSERT_EQ(r.status, TimeParametrizationStatus::kOk) << r.message;
  expect_limits_or_reported(r, vp, o);
  EXPECT_LT(r.max_time_deviation_s, o.time_tolerance_s);
  // Without the learning correction (one pass) the deviation is larger.
  o.max_timing_iterations = 1;
  const auto once = time_parametrize_timed(w, t, vp, o);
  EXPECT_GT(once.max_time_deviation_s, 2.0 * r.max_time_deviation_s);
  RecordProperty("max_time_deviation_s", std::to_string(r.max_time_deviation_s));
  RecordProperty("one_pass_deviation_s", std::to_string(once.max_time_deviation_s));
}

TEST(TimeParametrization, BadInputNamesTheField) {
  const auto vp = default_vehicle();
  EXPECT_NE(time_parametrize({{0, 0, 0}}, vp).message.find("waypoints_m"), std::string::npos);
  const auto nan = time_parametrize({{0, 0, 0}, {1, std::nan(""), 0}}, vp);
  EXPECT_EQ(nan.status, TimeParametrizationStatus::kInvalidInput);
  EXPECT_NE(nan.message.find("waypoints_m[1]"), std::string::npos);
  TimeParametrizationOptions o;
  o.control_period_s = 0.0;
  EXPECT_NE(
      time_parametrize({{0, 0, 0}, {100, 0, 0}}, vp, o).message.find("options.control_period_s"),
      std::string::npos);
  auto bad = vp;
  bad.min_turn_radius_m = -1.0;
  EXPECT_NE(
      time_parametrize({{0, 0, 0}, {100, 0, 0}}, bad).message.find("vehicle.min_turn_radius_m"),
      std::string::npos);
  const auto t = time_parametrize_timed({{0, 0, 0}, {100, 0, 0}, {200, 0, 0}}, {0.0, 5.0, 5.0}, vp);
  EXPECT_EQ(t.status, TimeParametrizationStatus::kInvalidInput);
  EXPECT_NE(t.message.find("times_s[2]"), std::string::npos);
  EXPECT_FALSE(t.reference.has_value());
}

}  // namespace
}  // namespace ridgeline::planning
