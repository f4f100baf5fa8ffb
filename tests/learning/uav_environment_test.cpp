// The DDPG environment (learning/uav_environment.hpp): observation values and reward terms on
// hand-made states, the action mapping against the maneuver limits, episodes that end as they
// must (reached, terrain, threat), and the randomization's ranges and determinism.
#include "learning/uav_environment.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.hpp"

namespace ridgeline::learning {
namespace {

constexpr double kTol = 1e-6;  // the observation is float: ~7 significant digits

std::shared_ptr<world::PeakTerrain> flat(double height_m = 0.0) {
  world::PeakTerrainConfig c;
  c.base_elevation_m = height_m;
  return std::make_shared<world::PeakTerrain>(c);
}

vehicle::State state_at(const Vec3& p, double psi, double v = 10.0) {
  vehicle::State s;
  s << p.x(), p.y(), p.z(), psi, v, 0.0, 0.0;
  return s;
}

ObservationInput basic_input(const world::Terrain& terrain) {
  ObservationInput in;
  in.state = state_at(Vec3(0, 0, 100), 0.0);
  in.target_m = Vec3(100, 100, 150);
  in.terrain = &terrain;
  return in;
}

TEST(Observation, TargetTerrainAndBandOnFlatGround) {
  const auto terrain = flat();
  const vehicle::VehicleParams vp;
  const Observation o = make_observation(basic_input(*terrain), vp);
  EXPECT_NEAR(o[0], 0.0, kTol);  // at cruise speed
  EXPECT_NEAR(o[1], 0.0, kTol);
  EXPECT_NEAR(o[2], 0.0, kTol);
  // Target 45° to the left of the heading (east), 141.4 m away, 50 m up.
  EXPECT_NEAR(o[3], std::sqrt(0.5), kTol);
  EXPECT_NEAR(o[4], std::sqrt(0.5), kTol);
  EXPECT_NEAR(o[5], std::tanh(std::sqrt(2.0) * 100.0 / 300.0), kTol);
  EXPECT_NEAR(o[6], 0.5, kTol);
  // Clearance over h_safe: (100 − 0 − 20)/100 now and at every point ahead.
  for (int k = 7; k <= 19; ++k) EXPECT_NEAR(o[k], 0.8, kTol) << k;
  for (int k = 20; k <= 38; ++k) EXPECT_EQ(o[k], 0.0f) << k;  // no obstacle, calm
  EXPECT_NEAR(o[39], 0.6, kTol);                              // (100 − 40)/100
  EXPECT_NEAR(o[40], 2.0, kTol);                              // (500 − 100)/100 clipped at 2
}

TEST(Observation, BodyFrameFollowsTheHeading) {
  const auto terrain = flat();
  ObservationInput in = basic_input(*terrain);
  in.state = state_at(Vec3(0, 0, 100), kPi / 2);  // heading north
  in.target_m = Vec3(100, 0, 100);                // due east: to the right
  in.wind_m_s = Vec3(3, 0, 1);                    // from the west: blows to the right
  in.state[vehicle::kV] = 12.5;
  in.state[vehicle::kOmega] = 0.5;
  in.state[vehicle::kW] = -1.5;
  const vehicle::VehicleParams vp;
  const Observation o = make_observation(in, vp);
  EXPECT_NEAR(o[0], 0.5, kTol);   // (12.5 − 10)/5
  EXPECT_NEAR(o[1], 0.5, kTol);   // 0.5 rad/s · 10 m / 10 m/s
  EXPECT_NEAR(o[2], -0.5, kTol);  // −1.5/3
  EXPECT_NEAR(o[3], 0.0, kTol);
  EXPECT_NEAR(o[4], -1.0, kTol);
  EXPECT_NEAR(o[36], 0.0, kTol);
  EXPECT_NEAR(o[37], -0.6, kTol);
  EXPECT_NEAR(o[38], 0.2, kTol);
}

TEST(Observation, TerrainSamplesAheadMatchTheTerrainAtTheirPoints) {
  world::PeakTerrainConfig c;
  c.peaks.push_back({120.0, 30.0, 150.0, 60.0, 80.0});
  c.model_error_m = 2.0;
  const world::PeakTerrain terrain(c);
  ObservationInput in = basic_input(terrain);
  in.state = state_at(Vec3(0, 0, 100), 0.3);
  const Observation o = make_observation(in, vehicle::VehicleParams{});
  int k = 8;
  for (const double angle : kTerrainAngles_rad)
    for (const double d : kTerrainDistances_m) {
      const double x = d * std::cos(0.3 + angle), y = d * std::sin(0.3 + angle);
      const double expected =
          std::clamp((100.0 - terrain.height(x, y) - 2.0 - 20.0) / 100.0, -2.0, 2.0);
      EXPECT_NEAR(o[k], expected, kTol) << "angle " << angle << " distance " << d;
      ++k;
    }
  EXPECT_NEAR(o[7], std::clamp((100.0 - terrain.height(0, 0) - 22.0) / 100.0, -1.0, 2.0), kTol);
}

TEST(Observation, NearestObstacleFirstInTheBodyFrame) {
  const auto terrain = flat();
  ObservationInput in = basic_input(*terrain);
  in.state = state_at(Vec3(0, 0, 100), kPi / 2);  // heading north: body f = y, l = −x
  in.obstacles.push_back({Vec3(0, 400, 100), Vec3(0, 0, 0), 50.0});   // surface 350 m
  in.obstacles.push_back({Vec3(-90, 0, 130), Vec3(5, 0, 1), 40.0});   // surface ≈ 54.9 m
  in.obstacles.push_back({Vec3(0, -900, 100), Vec3(0, 0, 0), 10.0});  // third: not observed
  const Observation o = make_observation(in, vehicle::VehicleParams{});
  const double s1 = std::hypot(90.0, 30.0) - 40.0;
  EXPECT_EQ(o[20], 1.0f);
  EXPECT_NEAR(o[21], 0.0, kTol);           // forward
  EXPECT_NEAR(o[22], 90.0 / 300.0, kTol);  // 90 m to the left (west when heading north)
  EXPECT_NEAR(o[23], 30.0 / 300.0, kTol);
  EXPECT_NEAR(o[24], 0.0, kTol);  // moving east: to the right
  EXPECT_NEAR(o[25], -0.5, kTol);
  EXPECT_NEAR(o[26], 0.1, kTol);
  EXPECT_NEAR(o[27], std::tanh(s1 / 100.0), kTol);
  EXPECT_EQ(o[28], 1.0f);
  EXPECT_NEAR(o[29], 400.0 / 300.0, kTol);
  EXPECT_NEAR(o[35], std::tanh(3.5), kTol);
}

TEST(Observation, WithoutTerrainIsAnError) {
  ObservationInput in;
  EXPECT_THROW(make_observation(in, vehicle::VehicleParams{}), InputError);
}

TEST(Action, MapsTheUnitCubeOntoTheManeuverLimits) {
  const vehicle::VehicleParams vp;
  const vehicle::State s = state_at(Vec3(0, 0, 100), 0.0, 10.0);
  const vehicle::Input hi = action_to_command(Vec3(1, 1, 1), s, vp);
  EXPECT_DOUBLE_EQ(hi[0], 15.0);
  EXPECT_DOUBLE_EQ(hi[1], 1.0);                                          // v/R_min
  EXPECT_DOUBLE_EQ(hi[2], 3.0);                                          // w_max < v·tan 30°
  const vehicle::Input lo = action_to_command(Vec3(-7, -1, -1), s, vp);  // clipped to −1
  EXPECT_DOUBLE_EQ(lo[0], 5.0);
  EXPECT_DOUBLE_EQ(lo[1], -1.0);
  EXPECT_DOUBLE_EQ(lo[2], -3.0);
  const vehicle::Input nan = action_to_command(Vec3(std::nan(""), 0.0, 0.0), s, vp);
  EXPECT_DOUBLE_EQ(nan[0], 10.0);
  // At low speed the pitch limit bounds the climb: |w_c| ≤ v·tan θ_max.
  const vehicle::Input slow =
      action_to_command(Vec3(0, 0, 1), state_at(Vec3(0, 0, 100), 0, 5.0), vp);
  EXPECT_NEAR(slow[2], 5.0 * std::tan(vp.max_pitch_rad), 1e-12);
  // Property: every action in a grid maps inside clamp_to_limits' box.
  for (double a0 = -1; a0 <= 1; a0 += 0.5)
    for (double a1 = -1; a1 <= 1; a1 += 0.5)
      for (double a2 = -1; a2 <= 1; a2 += 0.5) {
        const vehicle::Input u = action_to_command(Vec3(a0, a1, a2), s, vp);
        EXPECT_TRUE(u.isApprox(vehicle::clamp_to_limits(u, s, vp)));
      }
}

TEST(Reward, TermsOfAHandMadeDecision) {
  RewardWeights w;
  RewardInput in;
  in.distance_before_m = 500.0;
  in.distance_after_m = 498.0;      // 2 m closer in 0.2 s at v0 = 10 m/s: progress 1
  in.clearance_over_safe_m = 10.0;  // half the 20 m band
  in.threat_surface_m = 25.0;       // 15 m beyond r_safe = 10 m: half the 30 m band
  in.action = Vec3(0.5, 0.5, -1.0);
  const RewardTerms r = compute_reward(in, w, 10.0, 0.2, 10.0);
  EXPECT_DOUBLE_EQ(r.progress, 1.0);
  EXPECT_DOUBLE_EQ(r.time, -0.05);
  EXPECT_DOUBLE_EQ(r.terrain, -0.5);
  EXPECT_DOUBLE_EQ(r.threat, -0.5);
  EXPECT_DOUBLE_EQ(r.effort, -0.05 * 1.25);
  EXPECT_DOUBLE_EQ(r.terminal, 0.0);
  EXPECT_DOUBLE_EQ(r.total(), 1.0 - 0.05 - 0.5 - 0.5 - 0.0625);

  in.clearance_over_safe_m = 50.0;
  in.threat_surface_m = 1e9;
  in.outcome = EpisodeOutcome::kReached;
  const RewardTerms reached = compute_reward(in, w, 10.0, 0.2, 10.0);
  EXPECT_DOUBLE_EQ(reached.terrain, 0.0);
  EXPECT_DOUBLE_EQ(reached.threat, 0.0);
  EXPECT_DOUBLE_EQ(reached.terminal, 50.0);
  for (const EpisodeOutcome o :
       {EpisodeOutcome::kTerrainCollision, EpisodeOutcome::kThreatCollision,
        EpisodeOutcome::kAltitudeViolation}) {
    in.outcome = o;
    EXPECT_DOUBLE_EQ(compute_reward(in, w, 10.0, 0.2, 10.0).terminal, -50.0);
  }
  in.outcome = EpisodeOutcome::kTimeout;
  EXPECT_DOUBLE_EQ(compute_reward(in, w, 10.0, 0.2, 10.0).terminal, 0.0);
}

EnvironmentOptions calm_options() {
  EnvironmentOptions o = task_environment(TrainingTask::kFlat);
  o.position_noise_m = 0.0;
  return o;
}

EpisodeSetup straight_episode(const Vec3& target) {
  EpisodeSetup e;
  e.terrain = flat();
  e.start = state_at(Vec3(0, 0, 100), 0.0);
  e.target_m = target;
  e.time_limit_s = 100.0;
  return e;
}

TEST(Environment, FlyingStraightAtCruiseReachesATargetAhead) {
  UavEnvironment env(calm_options());
  const double T = env.options().action_period_s;
  env.reset(straight_episode(Vec3(300, 0, 100)));
  StepResult step;
  double progress = 0.0;
  int steps = 0;
  do {
    step = env.step(Vec3::Zero());
    progress += step.reward.progress;
    ++steps;
  } while (!step.done() && steps < 1000);
  EXPECT_EQ(step.outcome, EpisodeOutcome::kReached);
  EXPECT_DOUBLE_EQ(step.reward.terminal, 50.0);
  // Progress sums to (300 − d_end)/(v0·T_a) with d_end ≤ the 30 m radius.
  EXPECT_GE(progress, (300.0 - 30.0) / (10.0 * T) - 1e-9);
  EXPECT_LE(progress, 300.0 / (10.0 * T) + 1e-9);
  // 270 m at 10 m/s: about 27 s (one control period's ±0.2 m of noise-free flight).
  EXPECT_NEAR(env.time_s(), 27.0, 0.1);
  // The episode ends at the control period that reaches the target, inside the last decision.
  EXPECT_LE(env.time_s(), steps * T + 1e-9);
  EXPECT_GT(env.time_s(), (steps - 1) * T);
}

TEST(Environment, DivingEndsInTheTerrain) {
  EnvironmentOptions o = calm_options();
  o.limits.altitude.min_m = -1000.0;  // only the terrain can stop the dive
  UavEnvironment env(o);
  env.reset(straight_episode(Vec3(3000, 0, 100)));
  StepResult step;
  int steps = 0;
  do {
    step = env.step(Vec3(0, 0, -1));
    ++steps;
  } while (!step.done() && steps < 1000);
  EXPECT_EQ(step.outcome, EpisodeOutcome::kTerrainCollision);
  EXPECT_DOUBLE_EQ(step.reward.terminal, -50.0);
  EXPECT_LT(env.true_state()[vehicle::kZ], 0.0);
  // 100 m at 3 m/s after the climb lag: a little over 33 s.
  EXPECT_NEAR(env.time_s(), 100.0 / 3.0, 2.0);
}

TEST(Environment, AThreatOnTheLineIsACollision) {
  UavEnvironment env(calm_options());
  EpisodeSetup e = straight_episode(Vec3(600, 0, 100));
  world::Threat th;
  th.name = "t";
  th.centre_m = Vec3(200, 0, 100);
  th.radius_m = 40.0;
  e.threats.push_back(th);
  Observation o = env.reset(e);
  EXPECT_EQ(o[20], 1.0f);  // sensed: its surface is 160 m away, within 300 m
  StepResult step;
  do step = env.step(Vec3::Zero());
  while (!step.done());
  EXPECT_EQ(step.outcome, EpisodeOutcome::kThreatCollision);
  EXPECT_NEAR(env.true_state()[vehicle::kX], 160.0, 2.5);  // one control step at 10 m/s ≈ 0.2 m
}

TEST(Environment, RateLimitsShapeTheCommand) {
  EnvironmentOptions o = calm_options();
  o.action_period_s = 0.2;
  UavEnvironment env(o);
  env.reset(straight_episode(Vec3(3000, 0, 100)));
  env.step(Vec3(0, 1, 0));
  // 10 control periods of 20 ms at 1.5 rad/s² allow 0.3 rad/s of the 1 rad/s asked for.
  EXPECT_NEAR(env.command()[vehicle::kTurnRateCmd], 0.3, 1e-9);
  env.step(Vec3(0, 1, 0));
  EXPECT_NEAR(env.command()[vehicle::kTurnRateCmd], 0.6, 1e-9);
}

TEST(Environment, RandomEpisodesAreDeterministicAndWithinTheirRanges) {
  const EnvironmentOptions o = task_environment(TrainingTask::kMountain);
  UavEnvironment env(o);
  const EpisodeRandomization& r = o.randomization;
  int with_threats = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    const EpisodeSetup a = env.random_episode(seed), b = env.random_episode(seed);
    EXPECT_EQ(a.start, b.start);
    EXPECT_EQ(a.target_m, b.target_m);
    ASSERT_EQ(a.threats.size(), b.threats.size());
    const double d = (a.target_m - a.start.head<3>()).head<2>().norm();
    EXPECT_GE(d, r.min_target_distance_m - 1e-9);
    EXPECT_LE(d, r.max_target_distance_m + 1e-9);
    for (const Vec3& p : {Vec3(a.start.head<3>()), a.target_m}) {
      EXPECT_GE(p.x(), 0.05 * r.area_m - 1e-9);
      EXPECT_LE(p.x(), 0.95 * r.area_m + 1e-9);
      EXPECT_NEAR(p.z(), std::clamp(a.terrain->height(p.x(), p.y()) + 60.0, 45.0, 495.0), 1e-9);
    }
    EXPECT_LE(static_cast<int>(a.threats.size()), r.max_threats);
    with_threats += !a.threats.empty();
    for (const world::Threat& th : a.threats) {
      EXPECT_GE(th.radius_m, r.min_threat_radius_m);
      EXPECT_LE(th.radius_m, r.max_threat_radius_m);
      EXPECT_GE(th.velocity_m_s.norm(), r.min_threat_speed_m_s - 1e-9);
      EXPECT_LE(th.velocity_m_s.norm(), r.max_threat_speed_m_s + 1e-9);
    }
    EXPECT_LE(a.wind.mean_m_s.norm(), r.max_mean_wind_m_s + 1e-9);
    EXPECT_NE(env.random_episode(seed + 1000).target_m, a.target_m);
  }
  EXPECT_GT(with_threats, 10);  // 0..3 threats, a few dropped near the start: most have some
  // Same seed, same episode: identical trajectories under the same actions.
  UavEnvironment e1(o), e2(o);
  e1.reset(7);
  e2.reset(7);
  for (int k = 0; k < 50; ++k) {
    const StepResult s1 = e1.step(Vec3(0.2, -0.3, 0.5)), s2 = e2.step(Vec3(0.2, -0.3, 0.5));
    EXPECT_EQ(s1.observation, s2.observation);
    if (s1.done()) break;
  }
}

TEST(Environment, InvalidOptionsNameTheField) {
  EnvironmentOptions o;
  o.action_period_s = 0.001;
  try {
    UavEnvironment env(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "action_period_s");
  }
  EXPECT_THROW(parse_training_task("valley"), InputError);
  EXPECT_EQ(parse_training_task("flat"), TrainingTask::kFlat);
}

}  // namespace
}  // namespace ridgeline::learning
