// Closed-loop tests of the UAV tracker (src/mpc/uav_tracker.*) and the references
// (src/mpc/reference.*).
//
// The truth is vehicle::rk4_step at 200 Hz with time constants that differ from the
// controller's (τ_v 0.5 → 0.65 s, τ_ω 0.2 → 0.15 s, τ_w 0.4 → 0.5 s): model mismatch is part of
// every closed-loop test. The controller runs at 50 Hz with its defaults (0.1 s × 40, Nc = 10).
#include "mpc/uav_tracker.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace ridgeline::mpc {
namespace {

using vehicle::Input;
using vehicle::State;

constexpr double kControlPeriod = 0.02;
constexpr int kSubsteps = 4;  // 200 Hz truth

vehicle::VehicleParams truth_params() {
  vehicle::VehicleParams p;
  p.tau_v_s = 0.65;
  p.tau_omega_s = 0.15;
  p.tau_w_s = 0.5;
  return p;
}

State state_on(const ReferencePoint& r) {
  State s;
  s << r.position_m, r.heading_rad, r.speed_m_s, r.turn_rate_rad_s, r.climb_rate_m_s;
  return s;
}

// Gusts: per component an Ornstein–Uhlenbeck process (std σ, correlation time τ) around the
// mean, updated at the truth rate; the anemometer adds white noise. Seeded.
class GustModel {
 public:
  GustModel(Vec3 mean, double std_m_s, double tau_s, double noise_m_s, unsigned seed)
      : mean_(mean), std_(std_m_s), tau_(tau_s), noise_(noise_m_s), rng_(seed) {}
  Vec3 advance(double dt) {
    const double a = std::exp(-dt / tau_);
    const double b = std_ * std::sqrt(1.0 - a * a);
    for (int c = 0; c < 3; ++c) gust_[c] = a * gust_[c] + b * normal_(rng_) * (c == 2 ? 0.3 : 1.0);
    return mean_ + gust_;
  }
  Vec3 measure(const Vec3& truth) {
    return truth + noise_ * Vec3(normal_(rng_), normal_(rng_), normal_(rng_));
  }

 private:
  Vec3 mean_;
  double std_, tau_, noise_;
  std::mt19937 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  Vec3 gust_ = Vec3::Zero();
};

struct Scenario {
  double duration_s = 30.0;
  Vec3 mean_wind_m_s = Vec3::Zero();
  double gust_std_m_s = 0.0;
  double gust_tau_s = 5.0;
  double wind_noise_m_s = 0.0;
  bool measure_wind = true;  ///< false: the controller is told there is no wind
  unsigned seed = 1;
  std::vector<world::Threat> threats;
  std::vector<messages::PredictedTrajectory> neighbours;
  const world::Terrain* terrain = nullptr;
  bool wrap_heading = true;  ///< the truth reports ψ wrapped to (−π, π]
  State initial = State::Zero();
  double error_from_s = 5.0;  ///< RMSE window start
};

struct Log {
  double rmse_m = 0.0;
  double final_error_m = 0.0;
  double max_error_m = 0.0;
  double max_limit_violation = 0.0;  // |u − clamp_to_limits(u)| over all steps
  double max_rate_excess = 0.0;      // max(|Δu| − rate·T) over all steps and inputs
  double max_rate_used[3] = {0, 0, 0};
  double min_threat_clearance_flown_m = 1e9;
  double min_threat_clearance_predicted_m = 1e9;
  double min_terrain_clearance_m = 1e9;
  double min_separation_m = 1e9;
  double max_slack_m = 0.0;
  double max_terrain_slack_m = 0.0;
  int fallbacks = 0;
  int clamped = 0;
  int steps = 0;
  std::vector<double> step_times_us;
};

Log run(const UavTrackerOptions& options, const ReferenceTrajectory& ref, const Scenario& sc) {
  UavTracker tracker(options, world::SafetyLimits{});
  const vehicle::VehicleParams truth = truth_params();
  GustModel wind(sc.mean_wind_m_s, sc.gust_std_m_s, sc.gust_tau_s, sc.wind_noise_m_s, sc.seed);
  Vec3 w = wind.advance(0.0);
  State s = sc.initial;
  Input u_prev = Input::Zero();
  bool first = true;
  Log log;
  double sq = 0.0;
  int n_err = 0;
  const double rates[3] = {options.max_speed_cmd_rate_m_s2, options.max_turn_cmd_rate_rad_s2,
                           options.max_climb_cmd_rate_m_s2};
  TrackerEnvironment env{sc.threats, sc.neighbours, sc.terrain};
  const int steps = static_cast<int>(std::lround(sc.duration_s / kControlPeriod));
  for (int k = 0; k < steps; ++k) {
    const double t = k * kControlPeriod;
    const Vec3 w_meas = sc.measure_wind ? wind.measure(w) : Vec3::Zero();
    const UavTrackerResult& r = tracker.step(t, s, w_meas, ref, env);
    log.step_times_us.push_back(r.step_time_us);
    const Input u = r.command;
    log.max_limit_violation =
        std::max(log.max_limit_violation,
                 (u - vehicle::clamp_to_limits(u, s, options.vehicle)).cwiseAbs().maxCoeff());
    if (!first) {
      for (int c = 0; c < 3; ++c) {
        const double du = std::abs(u[c] - u_prev[c]);
        log.max_rate_excess = std::max(log.max_rate_excess, du - rates[c] * kControlPeriod);
        log.max_rate_used[c] = std::max(log.max_rate_used[c], du / (rates[c] * kControlPeriod));
      }
    }
    first = false;
    u_prev = u;
    log.fallbacks += r.fallback ? 1 : 0;
    log.max_slack_m = std::max(log.max_slack_m, r.max_slack_m());
    log.max_terrain_slack_m = std::max(log.max_terrain_slack_m,
                                       r.slack_m[static_cast<int>(SoftConstraintKind::kTerrain)]);
    for (const world::Threat& th : sc.threats) {
      for (int j = 0; j < r.predicted_positions_m.cols(); ++j) {
        const double tj = r.first_prediction_time_s + j * r.prediction_step_s;
        if (!th.active(tj)) continue;
        const Vec3 pj = r.predicted_positions_m.col(j);
        log.min_threat_clearance_predicted_m = std::min(
            log.min_threat_clearance_predicted_m, (pj - th.centre_at(tj)).norm() - th.radius_m);
      }
    }
    // Truth at 200 Hz.
    for (int i = 0; i < kSubsteps; ++i) {
      const double h = kControlPeriod / kSubsteps;
      s = vehicle::rk4_step(s, u, w, truth, h);
      w = wind.advance(h);
      const double ti = t + (i + 1) * h;
      for (const world::Threat& th : sc.threats) {
        if (th.active(ti)) {
          log.min_threat_clearance_flown_m =
              std::min(log.min_threat_clearance_flown_m,
                       (s.head<3>() - th.centre_at(ti)).norm() - th.radius_m);
        }
      }
      if (sc.terrain != nullptr) {
        log.min_terrain_clearance_m =
            std::min(log.min_terrain_clearance_m, s[vehicle::kZ] - sc.terrain->height(s[0], s[1]));
      }
      for (const messages::PredictedTrajectory& nb : sc.neighbours) {
        log.min_separation_m = std::min(
            log.min_separation_m, (s.head<3>() - messages::predicted_position(nb, ti)).norm());
      }
    }
    if (sc.wrap_heading) s[vehicle::kPsi] = wrap_angle(s[vehicle::kPsi]);
    const double t_next = t + kControlPeriod;
    const double e = (s.head<3>() - ref.at(t_next).position_m).norm();
    if (t_next >= sc.error_from_s) {
      sq += e * e;
      ++n_err;
      log.max_error_m = std::max(log.max_error_m, e);
    }
    log.final_error_m = e;
  }
  log.rmse_m = n_err > 0 ? std::sqrt(sq / n_err) : 0.0;
  log.steps = steps;
  return log;
}

// Straight and level flight east at 10 m/s, 100 m up.
class LineReference : public ReferenceTrajectory {
 public:
  explicit LineReference(double heading_rad = 0.0) : heading_(heading_rad) {}
  ReferencePoint at(double t_s) const override {
    ReferencePoint r;
    r.position_m = Vec3(10.0 * t_s * std::cos(heading_), 10.0 * t_s * std::sin(heading_), 100.0);
    r.heading_rad = heading_;
    r.speed_m_s = 10.0;
    return r;
  }

 private:
  double heading_;
};

void expect_limits_held(const Log& log) {
  // clamp_to_limits is the definition of the limits (eq. 2–3): a command it changes violates
  // them. Exactly zero is expected since the tracker applies the same clamp last.
  EXPECT_EQ(log.max_limit_violation, 0.0);
  // Rate limits per control period; 1e-12 allows the rounding of u_prev ± rate·T.
  EXPECT_LE(log.max_rate_excess, 1e-12);
  EXPECT_EQ(log.fallbacks, 0);
}

// A constant 3 m/s wind (2.4 m/s crosswind, 1.8 m/s headwind) that the controller does NOT
// measure, plus the τ mismatch: only the incremental form's integral action (the measured
// increment Δs carries the drift) can remove the steady-state error.
TEST(UavTracker, IntegralActionRemovesSteadyStateErrorOfUnmeasuredConstantWind) {
  UavTrackerOptions o;
  Scenario sc;
  sc.duration_s = 40.0;
  sc.mean_wind_m_s = Vec3(-1.8, 2.4, 0.0);
  sc.measure_wind = false;
  LineReference ref;
  sc.initial = state_on(ref.at(0.0));
  const Log log = run(o, ref, sc);
  // Without integral action the error would settle at about the drift the controller does not
  // see times its response time (3 m/s × ~1 s ≈ 3 m); a residual of 1 cm after 40 s shows the
  // bias is gone (the transient decays within ~10 s).
  EXPECT_LT(log.final_error_m, 0.01);
  expect_limits_held(log);
}

// Gust model for the circle and helix: mean 2 m/s from the south-west plus OU gusts of 1 m/s
// std (5 s correlation) — the DESIGN's "2 m/s mean, gusts < 3 m/s" — measured with 0.2 m/s noise.
Scenario gusty(unsigned seed) {
  Scenario sc;
  sc.duration_s = 60.0;
  sc.mean_wind_m_s = Vec3(1.4, 1.4, 0.0);
  sc.gust_std_m_s = 1.0;
  sc.gust_tau_s = 5.0;
  sc.wind_noise_m_s = 0.2;
  sc.seed = seed;
  return sc;
}

// RMSE bound for gusty tracking: the wind changes by about σ·√(2·Δt/τ) ≈ 1·√(2·0.1/5) = 0.2 m/s
// within one prediction step, and measured Δs lags it by up to one step; the loop's response
// time is about 1 s (τ_v + prediction lag), so the position excursion a gust change causes before
// it is corrected is of order 0.2 m/s × 1 s × a few ≈ 0.5 m. We require RMSE < 1 m and max < 3 m
// (the paper reports 0.02–0.04 "km" on its scale; these bounds are far tighter).
HelixReference circle_150m() {
  HelixReference::Config c;
  c.centre_m = Vec3(0.0, 0.0, 120.0);
  c.radius_m = 150.0;
  c.speed_m_s = 10.0;
  return HelixReference(c);
}

class CircleTracking : public ::testing::TestWithParam<LinearizationPoint> {};

// Both linearization points track the circle (near the reference they coincide to first order).
TEST_P(CircleTracking, TracksCircleUnderGustyWind) {
  const HelixReference ref = circle_150m();
  Scenario sc = gusty(3);
  sc.initial = state_on(ref.at(0.0));
  UavTrackerOptions o;
  o.linearization = GetParam();
  const Log log = run(o, ref, sc);
  EXPECT_LT(log.rmse_m, 1.0);
  EXPECT_LT(log.max_error_m, 3.0);
  expect_limits_held(log);
  std::vector<double> times = log.step_times_us;
  std::sort(times.begin(), times.end());
  std::printf("circle: RMSE %.3f m, max %.3f m; step time median %.0f us, p99 %.0f us\n",
              log.rmse_m, log.max_error_m, times[times.size() / 2], times[times.size() * 99 / 100]);
}
INSTANTIATE_TEST_SUITE_P(UavTracker, CircleTracking,
                         ::testing::Values(LinearizationPoint::kPreviousPrediction,
                                           LinearizationPoint::kReference));

// Feed-forward of the measured wind (through Δd, header of uav_tracker.hpp) must help: the
// same gusts, once measured (0.2 m/s noise) and once not, on the same seed. Measured: RMSE
// 0.30 m vs 0.37 m without; 0.95 demands a clear gain, not the exact figure.
TEST(UavTracker, MeasuredWindFeedForwardReducesTrackingError) {
  const HelixReference ref = circle_150m();
  Scenario sc = gusty(3);
  sc.initial = state_on(ref.at(0.0));
  const Log with_ff = run(UavTrackerOptions{}, ref, sc);
  sc.measure_wind = false;
  const Log without_ff = run(UavTrackerOptions{}, ref, sc);
  EXPECT_LT(with_ff.rmse_m, 0.95 * without_ff.rmse_m);
  std::printf("feed-forward: RMSE %.3f m with, %.3f m without\n", with_ff.rmse_m,
              without_ff.rmse_m);
}

TEST(UavTracker, TracksClimbingHelixUnderGustyWind) {
  HelixReference::Config c;
  c.centre_m = Vec3(200.0, -100.0, 60.0);
  c.radius_m = 100.0;
  // The cruise speed: a faster reference plus a 2 m/s mean headwind and gusts would ask for
  // more than the 15 m/s top of the speed band (the error would then be physical, not the
  // controller's).
  c.speed_m_s = 10.0;
  c.climb_rate_m_s = 1.5;
  c.turn_left = false;  // clockwise: exercises the other sign of ω and the heading wrap
  HelixReference ref(c);
  Scenario sc = gusty(5);
  sc.initial = state_on(ref.at(0.0));
  const Log log = run(UavTrackerOptions{}, ref, sc);
  EXPECT_LT(log.rmse_m, 1.0);
  EXPECT_LT(log.max_error_m, 3.0);
  expect_limits_held(log);
  std::printf("helix: RMSE %.3f m, max %.3f m\n", log.rmse_m, log.max_error_m);
}

// Starting 60 m off a westbound line (heading ±π, where the wrapped state heading flips sign)
// facing the wrong way: the limits saturate, and must hold at every step; the heading wrap
// must not make the vehicle spin.
TEST(UavTracker, LargeInitialErrorSaturatesButRespectsLimitsAcrossHeadingWrap) {
  LineReference ref(kPi);
  Scenario sc;
  sc.duration_s = 40.0;
  sc.initial = state_on(ref.at(0.0));
  sc.initial[vehicle::kY] += 60.0;
  sc.initial[vehicle::kPsi] = 0.5 * kPi;  // flying north, away from the line
  sc.error_from_s = 30.0;
  const UavTrackerOptions o;
  const Log log = run(o, ref, sc);
  expect_limits_held(log);
  // The turn-rate and speed rate limits were reached (saturation actually happened).
  EXPECT_GT(log.max_rate_used[1], 0.999);
  EXPECT_GT(log.max_rate_used[0], 0.999);
  // Converged: an unrecovered spin or a wrong-way loop would leave errors of tens of metres.
  EXPECT_LT(log.max_error_m, 0.5);
}

// A static threat sphere (R = 30 m) centred on the circle where the UAV arrives at t ≈ 25 s,
// reported at t = 2 s. Both every predicted trajectory (from the moment it is known) and the
// flown path must stay outside the sphere.
TEST(UavTracker, AvoidsThreatSphereOnTheReference) {
  HelixReference::Config c;
  c.centre_m = Vec3(0.0, 0.0, 120.0);
  c.radius_m = 150.0;
  c.speed_m_s = 10.0;
  HelixReference ref(c);
  Scenario sc = gusty(7);
  sc.duration_s = 45.0;
  world::Threat th;
  th.name = "on-path";
  th.centre_m = ref.at(25.0).position_m;
  th.radius_m = 30.0;
  th.appear_s = 2.0;
  th.vanish_s = 1e9;
  sc.threats.push_back(th);
  sc.initial = state_on(ref.at(0.0));
  const Log log = run(UavTrackerOptions{}, ref, sc);
  EXPECT_GT(log.min_threat_clearance_predicted_m, 0.0);
  EXPECT_GT(log.min_threat_clearance_flown_m, 0.0);
  expect_limits_held(log);
  std::printf("threat: min clearance predicted %.2f m, flown %.2f m, max slack %.3f m\n",
              log.min_threat_clearance_predicted_m, log.min_threat_clearance_flown_m,
              log.max_slack_m);
}

// A moving threat crossing the line, and a neighbour flying head-on along the same line:
// both are avoided.
TEST(UavTracker, AvoidsMovingThreatAndHeadOnNeighbour) {
  LineReference ref;
  Scenario sc;
  sc.duration_s = 40.0;
  world::Threat th;
  th.centre_m = Vec3(150.0, -120.0, 100.0);  // crosses y = 0 at t ≈ 15 + 2 = 17 s
  th.velocity_m_s = Vec3(0.0, 8.0, 0.0);
  th.radius_m = 20.0;
  th.appear_s = 2.0;
  sc.threats.push_back(th);
  messages::PredictedTrajectory nb;  // at x = 350 − 10 t on the line: meets the UAV at t ≈ 17.5 s
  nb.uav = 2;
  nb.step_s = 1.0;
  nb.stamp_s = -1.0;  // the first position at t = 0
  for (int i = 0; i <= 60; ++i) nb.positions_m.push_back(Vec3(350.0 - 10.0 * i, 0.0, 100.0));
  sc.neighbours.push_back(nb);
  sc.initial = state_on(ref.at(0.0));
  const Log log = run(UavTrackerOptions{}, ref, sc);
  EXPECT_GT(log.min_threat_clearance_flown_m, 0.0);
  EXPECT_GT(log.min_threat_clearance_predicted_m, 0.0);
  // d_safe = 10 m; the neighbour is a point moving exactly as broadcast, the model mismatch
  // may eat into the soft constraint's margin by ≈ 1 m.
  EXPECT_GT(log.min_separation_m, 9.0);
  expect_limits_held(log);
  std::printf("moving threat: flown clearance %.2f m; separation %.2f m\n",
              log.min_threat_clearance_flown_m, log.min_separation_m);
}

// A tiny local terrain: a Gaussian hill 110 m high on the path of a line flown at 100 m.
class HillTerrain : public world::Terrain {
 public:
  double height(double x, double y) const override {
    return 110.0 * std::exp(-std::pow((x - 200.0) / 80.0, 2) - std::pow(y / 80.0, 2));
  }
  Vec2 gradient(double x, double y) const override {
    const double h = height(x, y);
    return Vec2(-2.0 * (x - 200.0) / (80.0 * 80.0) * h, -2.0 * y / (80.0 * 80.0) * h);
  }
};

TEST(UavTracker, KeepsTerrainClearanceOverAHill) {
  LineReference ref;
  HillTerrain hill;
  Scenario sc;
  sc.duration_s = 35.0;
  sc.terrain = &hill;
  sc.initial = state_on(ref.at(0.0));
  const Log log = run(UavTrackerOptions{}, ref, sc);
  // The hill needs a 30 m climb (to 110 + 20 m); its steepest slope (1.2) would ask for 12 m/s
  // of climb at 10 m/s, and the 4 s horizon sees it only 40 m ahead. At w_max = 3 m/s the plan
  // cannot keep the full h_safe = 20 m and must say so: the terrain slack reports the shortfall.
  // The flown clearance may fall short of h_safe only by what was reported, plus 1 m for the
  // truth's model mismatch (τ_w) and the linearization of the curved hill between re-plans.
  const double h_safe = world::SafetyLimits{}.terrain_clearance_m;
  EXPECT_GT(log.min_terrain_clearance_m, h_safe - log.max_terrain_slack_m - 1.0);
  EXPECT_GT(log.min_terrain_clearance_m, 10.0);  // and the UAV is never near the ground
  expect_limits_held(log);
  std::printf("terrain: min clearance %.2f m, max slack %.3f m\n", log.min_terrain_clearance_m,
              log.max_slack_m);
}

// The soft rows the tracker hands to the MPC, against their equations (step 6 of
// uav_tracker.hpp) computed here from the public pieces (Threat::centre_at, the broadcast
// prediction, Terrain::height and gradient): a moving threat whose window opens and closes
// inside the horizon and whose centre crosses the nominal at one step (the fallback normal,
// towards the UAV), a neighbour's broadcast prediction, and a peak terrain with a model error.
// After reset() the nominal positions are the reference's, so the test knows p̄_j. Every row's
// step, kind, source, normal and bound, in the order added; Np = 41, not a multiple of the four
// steps the sphere rows take at once. (The reference's batch sample and at() may differ in the
// last bits: the values are compared to 1e-9.)
TEST(UavTracker, SoftRowsFollowTheirEquations) {
  UavTrackerOptions o;
  o.prediction_horizon = 41;
  const world::SafetyLimits limits;
  UavTracker tracker(o, limits);
  HelixReference::Config c;
  c.centre_m = Vec3(0.0, 0.0, 120.0);
  c.radius_m = 150.0;
  c.speed_m_s = 12.0;
  c.climb_rate_m_s = 0.5;
  const HelixReference ref(c);
  world::PeakTerrainConfig tc;
  tc.peaks = {{120.0, 60.0, 95.0, 60.0, 45.0}, {-80.0, 130.0, 70.0, 50.0, 80.0}};
  tc.model_error_m = 3.0;
  const world::PeakTerrain terrain(tc);
  const double dt = o.prediction_step_s, activation = o.activation_distance_m;
  const int np = o.prediction_horizon;
  for (const double t : {0.0, 1.3, 7.72}) {
    SCOPED_TRACE(t);
    const int crossing = 17;  // the threat's centre sits on p̄ at this step
    const double t_crossing = t + (crossing + 1) * dt;
    world::Threat threat;
    threat.velocity_m_s = Vec3(3.0, -2.0, 0.5);
    threat.radius_m = 25.0;
    threat.appear_s = t + 0.55;  // rows from step 5 to step 29
    threat.vanish_s = t + 3.05;
    threat.centre_m =
        ref.at(t_crossing).position_m - threat.velocity_m_s * (t_crossing - threat.appear_s);
    messages::PredictedTrajectory neighbour;  // flying the reference 15 m off
    neighbour.uav = 2;
    neighbour.step_s = 0.25;
    neighbour.stamp_s = t - 0.5;
    for (int i = 0; i < 30; ++i) {
      const double ti = neighbour.stamp_s + (i + 1) * neighbour.step_s;
      neighbour.positions_m.push_back(ref.at(ti).position_m + Vec3(12.0, -9.0, 0.0));
    }
    const std::vector<world::Threat> threats{threat};
    const std::vector<messages::PredictedTrajectory> neighbours{neighbour};
    const TrackerEnvironment env{threats, neighbours, &terrain};
    State state = state_on(ref.at(t));  // where p̄_j sits on c_j the normal points to the UAV
    tracker.reset(Input(c.speed_m_s, c.speed_m_s / c.radius_m, c.climb_rate_m_s));
    tracker.step(t, state, Vec3::Zero(), ref, env);

    struct Row {
      int step, kind, source;
      Vec3 normal;
      double bound;
    };
    std::vector<Row> expected;
    std::vector<int> fallback_steps;  // the steps whose row took the fallback normal
    const auto margin = [&](int j) {
      return std::min(o.wind_error_bound_m_s * (j + 1) * dt, o.max_robust_margin_m);
    };
    // n_jᵀ p_j ≥ n_jᵀ c_j + need, n_j from c_j to p̄_j (to the UAV where p̄_j sits on c_j).
    const auto sphere_row = [&](int j, SoftConstraintKind kind, const Vec3& centre, double need) {
      const Vec3 pbar = ref.at(t + (j + 1) * dt).position_m;
      const double distance = (pbar - centre).norm();
      if (distance - need > activation) return;
      if (distance <= 1e-6) fallback_steps.push_back(j);
      const Vec3 n = distance > 1e-6 ? Vec3((pbar - centre) / distance)
                                     : Vec3((state.head<3>() - centre).normalized());
      expected.push_back({j, static_cast<int>(kind), 0, n, n.dot(centre) + need});
    };
    for (int j = 0; j < np; ++j) {
      const double tj = t + (j + 1) * dt;
      if (!threat.active(tj)) continue;
      sphere_row(j, SoftConstraintKind::kThreat, threat.centre_at(tj),
                 threat.radius_m + limits.threat_margin_m + margin(j));
    }
    for (int j = 0; j < np; ++j) {
      sphere_row(j, SoftConstraintKind::kNeighbour,
                 messages::predicted_position(neighbour, t + (j + 1) * dt), limits.separation_m);
    }
    for (int j = 0; j < np; ++j) {
      const Vec3 pbar = ref.at(t + (j + 1) * dt).position_m;
      const double h = terrain.height(pbar.x(), pbar.y());
      const Vec2 g = terrain.gradient(pbar.x(), pbar.y());
      const double required = limits.terrain_clearance_m + margin(j) + tc.model_error_m;
      if (pbar.z() - h - required > activation) continue;
      // z − ∇H·(p − p̄)_xy ≥ H(p̄) + h_safe + m_j + e_H
      expected.push_back({j, static_cast<int>(SoftConstraintKind::kTerrain), 0,
                          Vec3(-g.x(), -g.y(), 1.0), h + required - g.dot(pbar.head<2>())});
    }
    // The cases are there: the threat's window cuts the horizon at both ends (its rows run
    // from step 5 to step 29), the fallback normal at the crossing only, rows of every kind.
    int first_threat_step = np, last_threat_step = -1, terrain_rows = 0, neighbour_rows = 0;
    for (const Row& row : expected) {
      if (row.kind == 0) {
        first_threat_step = std::min(first_threat_step, row.step);
        last_threat_step = std::max(last_threat_step, row.step);
      }
      neighbour_rows += row.kind == 1 ? 1 : 0;
      terrain_rows += row.kind == 2 ? 1 : 0;
    }
    EXPECT_EQ(first_threat_step, 5);
    EXPECT_EQ(last_threat_step, 29);
    EXPECT_EQ(fallback_steps, std::vector<int>{crossing});
    EXPECT_GT(neighbour_rows, 0);
    EXPECT_GT(terrain_rows, 0);
    EXPECT_LT(terrain_rows, np);

    const IncrementalMpcData& d = tracker.mpc().data();
    ASSERT_EQ(d.soft_row_count, static_cast<int>(expected.size()));
    for (int r = 0; r < d.soft_row_count; ++r) {
      const Row& e = expected[static_cast<std::size_t>(r)];
      SCOPED_TRACE(::testing::Message() << "row " << r << " kind " << e.kind << " step " << e.step);
      EXPECT_EQ(d.soft_step[r], e.step);
      EXPECT_EQ(d.soft_group[r], e.kind);
      EXPECT_EQ(d.soft_source[r], e.source);
      EXPECT_LT((d.soft_normal.col(r) - e.normal).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_NEAR(d.soft_bound[r], e.bound, 1e-9 * (1.0 + std::abs(e.bound)));
    }
  }
}

// The tracker's prediction must agree with the vehicle model it linearizes: replaying the
// planned moves u_j = u_{k−1} + Σ Δu through the nonlinear Euler step (eq. 4) at Δt_p with the
// measured wind reproduces the predicted positions. Truth = model here (no mismatch), so the
// differences are the velocity form's own approximations: the measured Δs_k is the increment
// over the LAST 0.1 s (its heading lags by ω·Δt_p/2 ≈ 0.003 rad, ≈ 3 mm per step, ≈ 0.13 m
// over 40 steps) and the neglected second-order terms (≈ v·Δt_p·Δψ²/2 per step, ≈ 0.02 m).
// 0.3 m at 4 s (40 m flown) is several times that; a wrong sign or a missing wind term in the
// assembly would err by metres.
TEST(UavTracker, PredictionAgreesWithNonlinearEulerRollout) {
  const HelixReference ref = circle_150m();
  UavTrackerOptions o;
  UavTracker tracker(o, world::SafetyLimits{});
  State s = state_on(ref.at(0.0));
  const Vec3 wind(1.5, -1.0, 0.2);
  double max_diff = 0.0;
  for (int k = 0; k <= 300; ++k) {
    const double t = k * kControlPeriod;
    const UavTrackerResult& r = tracker.step(t, s, wind, ref, TrackerEnvironment{});
    if (k >= 100 && k % 50 == 0) {
      const IncrementalMpcResult& m = tracker.mpc().last_result();
      Input u = tracker.mpc().data().previous_input;
      State x = s;
      for (int j = 0; j < o.prediction_horizon; ++j) {
        if (j < o.control_horizon) u += m.moves.segment<3>(3 * j);
        x = vehicle::euler_step(x, u, wind, o.vehicle, o.prediction_step_s);
        max_diff = std::max(max_diff, (x.head<3>() - r.predicted_positions_m.col(j)).norm());
      }
    }
    for (int i = 0; i < kSubsteps; ++i) {
      s = vehicle::rk4_step(s, r.command, wind, o.vehicle, kControlPeriod / kSubsteps);
    }
  }
  EXPECT_LT(max_diff, 0.3);
  std::printf("prediction vs Euler rollout: max %.3f m\n", max_diff);
}

// cpu_time_period_steps = 3 reads the CPU clock on steps 0, 3, 6, ... only: those report a
// CPU time (≥ 0), the others NaN; 0 never reads it. The commands are those of a tracker timing
// every step (the clock is not an input).
TEST(UavTracker, CpuTimePeriodTimesEveryNthStepOnly) {
  const HelixReference ref = circle_150m();
  UavTrackerOptions every;
  UavTrackerOptions third;
  third.cpu_time_period_steps = 3;
  UavTrackerOptions never;
  never.cpu_time_period_steps = 0;
  UavTracker a(every, world::SafetyLimits{});
  UavTracker b(third, world::SafetyLimits{});
  UavTracker c(never, world::SafetyLimits{});
  const State s = state_on(ref.at(0.0));
  const Vec3 wind(1.0, 0.0, 0.0);
  for (int k = 0; k < 10; ++k) {
    const double t = k * kControlPeriod;
    const UavTrackerResult& ra = a.step(t, s, wind, ref, TrackerEnvironment{});
    const UavTrackerResult& rb = b.step(t, s, wind, ref, TrackerEnvironment{});
    const UavTrackerResult& rc = c.step(t, s, wind, ref, TrackerEnvironment{});
    EXPECT_GE(ra.step_cpu_time_us, 0.0);
    EXPECT_TRUE(std::isnan(rc.step_cpu_time_us)) << k;
    EXPECT_EQ(ra.command, rc.command) << k;
    if (k % 3 == 0) {
      EXPECT_GE(rb.step_cpu_time_us, 0.0) << k;
    } else {
      EXPECT_TRUE(std::isnan(rb.step_cpu_time_us)) << k;
    }
    EXPECT_EQ(ra.command, rb.command) << k;
  }
  third.cpu_time_period_steps = -1;
  try {
    UavTracker bad(third, world::SafetyLimits{});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "cpu_time_period_steps");
  }
}

// time_step_parts off: the parts are NaN, the whole step is still timed, and the commands and
// predictions are those of a tracker that times its parts (the clock is not an input). On, the
// parts are finite and sum to the step.
TEST(UavTracker, UntimedPartsAreNaNAndChangeNothing) {
  const HelixReference ref = circle_150m();
  UavTrackerOptions timed;
  UavTrackerOptions untimed;
  untimed.time_step_parts = false;
  UavTracker a(timed, world::SafetyLimits{});
  UavTracker b(untimed, world::SafetyLimits{});
  State s = state_on(ref.at(0.0));
  const Vec3 wind(1.0, 0.5, 0.0);
  for (int k = 0; k < 20; ++k) {
    const double t = k * kControlPeriod;
    const UavTrackerResult& ra = a.step(t, s, wind, ref, TrackerEnvironment{});
    const UavTrackerResult& rb = b.step(t, s, wind, ref, TrackerEnvironment{});
    ASSERT_TRUE(rb.qp_status == qp::QpStatus::kSolved) << k;
    EXPECT_EQ(ra.command, rb.command) << k;
    EXPECT_EQ(ra.predicted_positions_m, rb.predicted_positions_m) << k;
    EXPECT_GE(rb.step_time_us, 0.0) << k;
    EXPECT_GE(rb.qp_time_us, 0.0) << k;
    for (const double part : {rb.parts.linearization_us, rb.parts.condensing_us,
                              rb.parts.soft_rows_us, rb.parts.qp_us, rb.parts.other_us}) {
      EXPECT_TRUE(std::isnan(part)) << k;
    }
    const UavTrackerStepParts& p = ra.parts;
    for (const double part : {p.linearization_us, p.condensing_us, p.soft_rows_us, p.qp_us}) {
      EXPECT_GE(part, 0.0) << k;
    }
    EXPECT_NEAR(p.linearization_us + p.condensing_us + p.soft_rows_us + p.qp_us + p.other_us,
                ra.step_time_us, 1e-9 * ra.step_time_us + 1e-12)
        << k;
    s = vehicle::rk4_step(s, ra.command, wind, timed.vehicle, kControlPeriod);
  }
}

TEST(UavTrackerOptionsCheck, RejectsBadOptionsNamingTheField) {
  UavTrackerOptions o;
  o.prediction_step_s = 0.0;
  try {
    UavTracker tracker(o, world::SafetyLimits{});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "prediction_step_s");
  }
  o = UavTrackerOptions{};
  o.control_horizon = 50;
  EXPECT_THROW((UavTracker{o, world::SafetyLimits{}}), InputError);
  // The limits are checked too, naming the scenario's field.
  world::SafetyLimits limits;
  limits.threat_margin_m = -1.0;
  try {
    UavTracker tracker(UavTrackerOptions{}, limits);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "safety.threat_margin_m");
  }
}

// SampledReference from a helix's positions reproduces the helix's heading, speed, turn and
// climb rates: central differences on a 0.5 s grid err by O((ωΔt)²) ≈ 1e-4 relative.
TEST(SampledReference, FromPositionsMatchesAnalyticHelix) {
  HelixReference::Config c;
  c.radius_m = 80.0;
  c.speed_m_s = 12.0;
  c.climb_rate_m_s = -1.0;
  c.turn_left = false;
  HelixReference helix(c);
  std::vector<double> times;
  std::vector<Vec3> pos;
  for (int i = 0; i <= 200; ++i) {
    times.push_back(0.5 * i);
    pos.push_back(helix.at(0.5 * i).position_m);
  }
  const SampledReference sampled = SampledReference::from_positions(times, pos);
  for (double t : {3.3, 41.0, 77.7}) {
    const ReferencePoint a = helix.at(t);
    const ReferencePoint b = sampled.at(t);
    // Linear interpolation of a circle between 6 m-apart samples sags by ≤ s²/(8R) ≈ 0.06 m.
    EXPECT_LT((a.position_m - b.position_m).norm(), 0.06);
    EXPECT_NEAR(wrap_angle(a.heading_rad - b.heading_rad), 0.0, 1e-3);
    // The chord speed is v·sin(ωΔt)/(ωΔt) ≈ v(1 − (ωΔt)²/6): 12·(0.075²/6) ≈ 0.011 m/s.
    EXPECT_NEAR(a.speed_m_s, b.speed_m_s, 0.015);
    EXPECT_NEAR(a.turn_rate_rad_s, b.turn_rate_rad_s, 1e-3);
    EXPECT_NEAR(a.climb_rate_m_s, b.climb_rate_m_s, 1e-9);
  }
  EXPECT_THROW(SampledReference::from_positions({0.0, 1.0, 1.0}, pos), InputError);
  EXPECT_THROW(SampledReference::from_positions({0.0, 1.0}, {Vec3::Zero(), Vec3::UnitZ()}),
               InputError);
}

void expect_same_point(const ReferencePoint& a, const ReferencePoint& b, const std::string& at) {
  EXPECT_EQ(a.position_m, b.position_m) << at;
  EXPECT_EQ(a.heading_rad, b.heading_rad) << at;
  EXPECT_EQ(a.speed_m_s, b.speed_m_s) << at;
  EXPECT_EQ(a.turn_rate_rad_s, b.turn_rate_rad_s) << at;
  EXPECT_EQ(a.climb_rate_m_s, b.climb_rate_m_s) << at;
}

// The tracker takes its Np + 1 samples with sample(): for a sampled reference they must be
// at()'s bit for bit, before its first sample, between uneven samples (several a sample, one
// sample skipped, headings across ±π), and past its last; a step of 0 repeats one time; times
// out of order in at_increasing are searched for.
TEST(SampledReference, SampleEqualsAtBitForBit) {
  std::vector<double> times{0.0, 0.3, 1.1, 1.2, 1.25, 2.5, 4.0, 4.05, 6.0};
  std::vector<Vec3> pos;
  for (std::size_t i = 0; i < times.size(); ++i) {
    const double a = 2.9 + 0.4 * static_cast<double>(i);  // around the −x axis: ψ crosses ±π
    pos.emplace_back(30.0 * std::cos(a) + times[i], 30.0 * std::sin(a), 100.0 - times[i]);
  }
  const SampledReference ref = SampledReference::from_positions(times, pos);
  for (const double step : {0.1, 0.0137, 0.0, 1.3}) {
    std::vector<ReferencePoint> out(75);
    const double t0 = -0.7;
    ref.sample(t0, step, out);
    for (std::size_t j = 0; j < out.size(); ++j) {
      const double t = t0 + static_cast<double>(j) * step;
      expect_same_point(out[j], ref.at(t),
                        "step " + std::to_string(step) + " t " + std::to_string(t));
    }
  }
  const std::vector<double> shuffled{1.22, 0.5, 5.0, 1.15, -2.0, 7.0, 3.0, 1.21};
  std::vector<ReferencePoint> out(shuffled.size());
  ref.at_increasing(shuffled, out);
  for (std::size_t j = 0; j < out.size(); ++j)
    expect_same_point(out[j], ref.at(shuffled[j]), "t " + std::to_string(shuffled[j]));
}

// A helix's samples take their sines and cosines four at a time (libmvec where the CPU has
// AVX2): the positions equal at()'s to round-off, everything else bit for bit; 41 samples are
// two batches and a tail.
TEST(HelixReference, SampleEqualsAtToRoundOff) {
  HelixReference::Config c;
  c.radius_m = 150.0;
  c.climb_rate_m_s = 0.7;
  c.phase0_rad = 2.0;
  c.t0_s = 3.0;
  for (const bool left : {true, false}) {
    c.turn_left = left;
    const HelixReference helix(c);
    std::vector<ReferencePoint> out(41);
    helix.sample(123.456, 0.1, out);
    for (std::size_t j = 0; j < out.size(); ++j) {
      const ReferencePoint a = helix.at(123.456 + static_cast<double>(j) * 0.1);
      EXPECT_LT((out[j].position_m - a.position_m).norm(), 1e-12 * 150.0) << j;
      EXPECT_EQ(out[j].position_m.z(), a.position_m.z()) << j;
      EXPECT_EQ(out[j].heading_rad, a.heading_rad) << j;
      EXPECT_EQ(out[j].speed_m_s, a.speed_m_s) << j;
      EXPECT_EQ(out[j].turn_rate_rad_s, a.turn_rate_rad_s) << j;
      EXPECT_EQ(out[j].climb_rate_m_s, a.climb_rate_m_s) << j;
    }
  }
}

}  // namespace
}  // namespace ridgeline::mpc
