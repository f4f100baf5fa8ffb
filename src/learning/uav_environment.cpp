#include "learning/uav_environment.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "world/terrain_synthesis.hpp"

namespace ridgeline::learning {
namespace {

// Sub-streams of an episode's seed.
constexpr std::uint64_t kTerrainStream = 0x5445525241;  // "TERRA"
constexpr std::uint64_t kLayoutStream = 0x4C41594F;     // "LAYO"
constexpr std::uint64_t kWindStream = 0x57494E44;       // "WIND"

float clampf(double v, double lo, double hi) { return static_cast<float>(std::clamp(v, lo, hi)); }

/// World xy → body (forward, left) for heading ψ.
Vec2 to_body(const Vec2& v, double psi) {
  const double c = std::cos(psi), s = std::sin(psi);
  return Vec2(c * v.x() + s * v.y(), -s * v.x() + c * v.y());
}

void require(bool ok, const char* field, const char* reason) {
  if (!ok) throw InputError(field, reason);
}

}  // namespace

Observation make_observation(const ObservationInput& in, const vehicle::VehicleParams& vp) {
  if (in.terrain == nullptr) throw InputError("terrain", "is required for an observation");
  Observation o{};
  const vehicle::State& s = in.state;
  const Vec3 p = s.head<3>();
  const double psi = s[vehicle::kPsi];
  const double v0 = vp.cruise_speed_m_s;
  const double error = in.terrain->model_error_m();
  auto clearance = [&](double x, double y) {
    return p.z() - in.terrain->height(x, y) - error - in.limits.terrain_clearance_m;
  };
  int k = 0;
  o[k++] = clampf((s[vehicle::kV] - v0) / vp.speed_band_m_s, -2.0, 2.0);
  o[k++] = clampf(s[vehicle::kOmega] * vp.min_turn_radius_m / v0, -2.0, 2.0);
  o[k++] = clampf(s[vehicle::kW] / vp.max_climb_rate_m_s, -2.0, 2.0);

  const Vec2 to_target = to_body(in.target_m.head<2>() - p.head<2>(), psi);
  const double d_h = to_target.norm();
  o[k++] = static_cast<float>(d_h > 1e-9 ? to_target.x() / d_h : 1.0);
  o[k++] = static_cast<float>(d_h > 1e-9 ? to_target.y() / d_h : 0.0);
  o[k++] = static_cast<float>(std::tanh(d_h / 300.0));
  o[k++] = clampf((in.target_m.z() - p.z()) / 100.0, -2.0, 2.0);

  o[k++] = clampf(clearance(p.x(), p.y()) / 100.0, -1.0, 2.0);
  for (const double angle : kTerrainAngles_rad) {
    const double a = psi + angle;
    for (const double d : kTerrainDistances_m)
      o[k++] =
          clampf(clearance(p.x() + d * std::cos(a), p.y() + d * std::sin(a)) / 100.0, -2.0, 2.0);
  }

  std::vector<std::pair<double, const ObstacleView*>> nearest;
  for (const ObstacleView& ob : in.obstacles)
    nearest.emplace_back((ob.centre_m - p).norm() - ob.radius_m, &ob);
  std::sort(nearest.begin(), nearest.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (int i = 0; i < kObservedObstacles; ++i) {
    if (i < static_cast<int>(nearest.size())) {
      const ObstacleView& ob = *nearest[static_cast<std::size_t>(i)].second;
      const Vec3 rel = ob.centre_m - p;
      const Vec2 rel_b = to_body(rel.head<2>(), psi);
      const Vec2 vel_b = to_body(ob.velocity_m_s.head<2>(), psi);
      o[k++] = 1.0f;
      o[k++] = clampf(rel_b.x() / 300.0, -2.0, 2.0);
      o[k++] = clampf(rel_b.y() / 300.0, -2.0, 2.0);
      o[k++] = clampf(rel.z() / 300.0, -2.0, 2.0);
      o[k++] = clampf(vel_b.x() / 10.0, -2.0, 2.0);
      o[k++] = clampf(vel_b.y() / 10.0, -2.0, 2.0);
      o[k++] = clampf(ob.velocity_m_s.z() / 10.0, -2.0, 2.0);
      o[k++] = static_cast<float>(std::tanh(nearest[static_cast<std::size_t>(i)].first / 100.0));
    } else {
      k += 8;
    }
  }

  const Vec2 wind_b = to_body(in.wind_m_s.head<2>(), psi);
  o[k++] = clampf(wind_b.x() / 5.0, -2.0, 2.0);
  o[k++] = clampf(wind_b.y() / 5.0, -2.0, 2.0);
  o[k++] = clampf(in.wind_m_s.z() / 5.0, -2.0, 2.0);
  o[k++] = clampf((p.z() - in.limits.altitude.min_m) / 100.0, 0.0, 2.0);
  o[k++] = clampf((in.limits.altitude.max_m - p.z()) / 100.0, 0.0, 2.0);
  return o;
}

vehicle::Input action_to_command(const Vec3& action, const vehicle::State& s,
                                 const vehicle::VehicleParams& vp) {
  Vec3 a = action;
  for (int i = 0; i < 3; ++i) a[i] = std::isfinite(a[i]) ? std::clamp(a[i], -1.0, 1.0) : 0.0;
  const vehicle::Input u(vp.cruise_speed_m_s + a[0] * vp.speed_band_m_s,
                         a[1] * vp.max_turn_rate_rad_s(s[vehicle::kV]),
                         a[2] * vp.max_climb_rate_m_s);
  return vehicle::clamp_to_limits(u, s, vp);
}

std::string_view to_string(EpisodeOutcome outcome) {
  switch (outcome) {
    case EpisodeOutcome::kRunning:
      return "running";
    case EpisodeOutcome::kReached:
      return "reached";
    case EpisodeOutcome::kTerrainCollision:
      return "terrain_collision";
    case EpisodeOutcome::kThreatCollision:
      return "threat_collision";
    case EpisodeOutcome::kAltitudeViolation:
      return "altitude_violation";
    case EpisodeOutcome::kTimeout:
      return "timeout";
  }
  return "unknown";
}

bool is_collision(EpisodeOutcome outcome) {
  return outcome == EpisodeOutcome::kTerrainCollision ||
         outcome == EpisodeOutcome::kThreatCollision ||
         outcome == EpisodeOutcome::kAltitudeViolation;
}

RewardTerms compute_reward(const RewardInput& in, const RewardWeights& w, double cruise_speed_m_s,
                           double action_period_s, double threat_margin_m) {
  RewardTerms r;
  r.progress = (in.distance_before_m - in.distance_after_m) / (cruise_speed_m_s * action_period_s);
  r.time = -w.time;
  r.terrain = -w.terrain * std::max(0.0, 1.0 - in.clearance_over_safe_m / w.terrain_band_m);
  r.threat =
      -w.threat * std::max(0.0, 1.0 - (in.threat_surface_m - threat_margin_m) / w.threat_band_m);
  r.effort = -w.effort * (in.action[1] * in.action[1] + in.action[2] * in.action[2]);
  if (in.outcome == EpisodeOutcome::kReached) r.terminal = w.success;
  if (is_collision(in.outcome)) r.terminal = -w.collision;
  return r;
}

void validate(const EnvironmentOptions& o) {
  const EpisodeRandomization& r = o.randomization;
  require(r.area_m > 0.0, "randomization.area_m", "must be positive");
  require(r.min_peaks >= 1 && r.max_peaks >= r.min_peaks, "randomization.min_peaks",
          "need 1 <= min_peaks <= max_peaks");
  require(r.min_target_distance_m > 0.0 && r.max_target_distance_m >= r.min_target_distance_m &&
              r.max_target_distance_m < r.area_m,
          "randomization.min_target_distance_m", "need 0 < min <= max target distance < area_m");
  require(r.max_threats >= 0, "randomization.max_threats", "must not be negative");
  require(
      o.control_period_s > 0.0 && o.truth_step_s > 0.0 && o.action_period_s >= o.control_period_s,
      "action_period_s", "need truth and control steps > 0 and action period >= control period");
  require(o.max_command_rate.allFinite() && o.max_command_rate.minCoeff() > 0.0, "max_command_rate",
          "must be positive and finite");
  require(o.target_radius_m > 0.0, "target_radius_m", "must be positive");
  world::validate(o.limits);
}

std::string_view to_string(TrainingTask task) {
  return task == TrainingTask::kFlat ? "flat" : "mountain";
}

TrainingTask parse_training_task(std::string_view text, const std::string& field) {
  for (const TrainingTask t : {TrainingTask::kMountain, TrainingTask::kFlat})
    if (text == to_string(t)) return t;
  throw InputError(field, fmt::format("unknown task '{}' (one of mountain, flat)", text));
}

EnvironmentOptions task_environment(TrainingTask task) {
  EnvironmentOptions o;
  if (task == TrainingTask::kFlat) {
    o.randomization.terrain = false;
    o.randomization.max_threats = 0;
    o.randomization.max_mean_wind_m_s = 0.0;
    o.randomization.max_gust_std_m_s = 0.0;
    o.randomization.min_target_distance_m = 150.0;
    o.randomization.max_target_distance_m = 300.0;
    o.randomization.area_m = 1000.0;
  }
  return o;
}

UavEnvironment::UavEnvironment(const EnvironmentOptions& options) : options_(options) {
  validate(options_);
  truth_params_ = options_.vehicle;
  truth_params_.tau_v_s *= options_.truth_time_constant_scale;
  truth_params_.tau_omega_s *= options_.truth_time_constant_scale;
  truth_params_.tau_w_s *= options_.truth_time_constant_scale;
}

EpisodeSetup UavEnvironment::random_episode(std::uint64_t seed) const {
  const EpisodeRandomization& r = options_.randomization;
  const EnvironmentOptions& o = options_;
  EpisodeSetup e;
  Rng rng(derive_seed(seed, kLayoutStream));
  if (r.terrain) {
    world::RandomPeaksOptions peaks;
    peaks.num_peaks =
        r.min_peaks + static_cast<int>(rng.uniform() * (r.max_peaks - r.min_peaks + 1));
    peaks.num_peaks = std::min(peaks.num_peaks, r.max_peaks);
    peaks.x_max_m = peaks.y_max_m = r.area_m;
    peaks.min_height_m = r.min_peak_height_m;
    peaks.max_height_m = r.max_peak_height_m;
    peaks.min_separation_m = std::min(300.0, 0.6 * r.area_m / std::sqrt(peaks.num_peaks));
    peaks.seed = derive_seed(seed, kTerrainStream);
    e.terrain = std::make_shared<world::PeakTerrain>(world::random_peaks(peaks));
  } else {
    e.terrain = std::make_shared<world::PeakTerrain>(world::PeakTerrainConfig{});
  }
  auto altitude = [&](const Vec2& xy) {
    return std::clamp(e.terrain->height(xy.x(), xy.y()) + r.height_above_terrain_m,
                      o.limits.altitude.min_m + 5.0, o.limits.altitude.max_m - 5.0);
  };
  // Start and target inside the area's inner 90 %, at a drawn distance.
  Vec2 start, target;
  for (int attempt = 0;; ++attempt) {
    start = Vec2(rng.uniform(0.05, 0.95), rng.uniform(0.05, 0.95)) * r.area_m;
    const double d = rng.uniform(r.min_target_distance_m, r.max_target_distance_m);
    const double bearing = rng.uniform(-kPi, kPi);
    target = start + d * Vec2(std::cos(bearing), std::sin(bearing));
    const bool inside =
        target.minCoeff() >= 0.05 * r.area_m && target.maxCoeff() <= 0.95 * r.area_m;
    if (inside || attempt > 1000) break;
  }
  e.start << start.x(), start.y(), altitude(start), rng.uniform(-kPi, kPi),
      o.vehicle.cruise_speed_m_s, 0.0, 0.0;
  e.target_m = Vec3(target.x(), target.y(), altitude(target));
  const double distance = (e.target_m - e.start.head<3>()).norm();
  e.time_limit_s =
      o.time_limit_factor * distance / o.vehicle.cruise_speed_m_s + o.time_limit_extra_s;

  // Threats cross the direct line near the time the UAV would pass there at cruise speed.
  const int n_threats = static_cast<int>(rng.uniform() * (r.max_threats + 1));
  const Vec2 line = target - start;
  const Vec2 normal = Vec2(-line.y(), line.x()).normalized();
  for (int i = 0; i < std::min(n_threats, r.max_threats); ++i) {
    world::Threat th;
    th.name = fmt::format("threat{}", i);
    th.radius_m = rng.uniform(r.min_threat_radius_m, r.max_threat_radius_m);
    const double speed = rng.uniform(r.min_threat_speed_m_s, r.max_threat_speed_m_s);
    const double f = rng.uniform(0.3, 0.8);
    const double along = rng.uniform(-40.0, 40.0);
    const Vec2 cross_xy = start + f * line + along * line.normalized();
    const double pass_s = f * line.norm() / o.vehicle.cruise_speed_m_s + rng.uniform(-10.0, 10.0);
    th.appear_s = rng.uniform(0.0, std::max(0.0, pass_s - 10.0));
    const double side = rng.uniform() < 0.5 ? -1.0 : 1.0;
    const Vec2 v_xy = side * speed * normal;
    const Vec2 c0 = cross_xy - v_xy * (pass_s - th.appear_s);
    const double z = altitude(cross_xy) + rng.uniform(-20.0, 20.0);
    th.centre_m = Vec3(c0.x(), c0.y(), z);
    th.velocity_m_s = Vec3(v_xy.x(), v_xy.y(), 0.0);
    th.vanish_s = th.appear_s + 400.0;
    // A threat that would swallow the start or the target at once is not a fair task.
    if ((th.centre_m - e.start.head<3>()).norm() < th.radius_m + 60.0) continue;
    if ((th.centre_at(e.time_limit_s) - e.target_m).norm() < th.radius_m + 40.0) continue;
    e.threats.push_back(th);
  }

  const double wind_speed = rng.uniform(0.0, r.max_mean_wind_m_s);
  const double wind_dir = rng.uniform(-kPi, kPi);
  e.wind.mean_m_s = Vec3(wind_speed * std::cos(wind_dir), wind_speed * std::sin(wind_dir), 0.0);
  e.wind.gust_std_m_s = rng.uniform(0.0, r.max_gust_std_m_s);
  e.wind.seed = derive_seed(seed, kWindStream);
  e.wind.gust_modes = 32;
  return e;
}

Observation UavEnvironment::reset(const EpisodeSetup& setup, std::uint64_t noise_seed) {
  require(setup.terrain != nullptr, "terrain", "an episode needs a terrain");
  require(setup.start.allFinite() && setup.target_m.allFinite(), "start",
          "start state and target must be finite");
  for (const world::Threat& th : setup.threats) world::validate(th, "threats[]");
  setup_ = setup;
  wind_ = std::make_unique<world::WindField>(setup_.wind);
  anemometer_ = std::make_unique<world::WindSensor>(setup_.wind, noise_seed);
  noise_ = Rng(derive_seed(noise_seed, 0x4E4F495345));  // "NOISE"
  state_ = setup_.start;
  command_ = vehicle::Input(state_[vehicle::kV], 0.0, 0.0);
  time_s_ = 0.0;
  wind_estimate_ = anemometer_->measure(*wind_, state_.head<3>(), time_s_);
  return observe();
}

Observation UavEnvironment::observe() {
  ObservationInput in;
  in.state = state_;
  for (int i = 0; i < 3; ++i) in.state[i] += options_.position_noise_m * noise_.normal();
  in.wind_m_s = wind_estimate_;
  in.target_m = setup_.target_m;
  in.terrain = setup_.terrain.get();
  in.limits = options_.limits;
  for (const world::Threat& th : setup_.threats)
    if (th.sensed_by(state_.head<3>(), options_.sensor_range_m, time_s_))
      in.obstacles.push_back({th.centre_at(time_s_), th.velocity_m_s, th.radius_m});
  return make_observation(in, options_.vehicle);
}

double UavEnvironment::clearance_over_safe_m(const Vec3& p) const {
  return p.z() - setup_.terrain->height(p.x(), p.y()) - setup_.terrain->model_error_m() -
         options_.limits.terrain_clearance_m;
}

double UavEnvironment::nearest_threat_surface_m(const Vec3& p) const {
  double best = 1e9;
  for (const world::Threat& th : setup_.threats)
    best = std::min(best, th.surface_distance(p, time_s_));
  return best;
}

EpisodeOutcome UavEnvironment::outcome() const {
  const Vec3 p = state_.head<3>();
  if (p.z() < setup_.terrain->height(p.x(), p.y())) return EpisodeOutcome::kTerrainCollision;
  if (nearest_threat_surface_m(p) < 0.0) return EpisodeOutcome::kThreatCollision;
  if (p.z() < options_.limits.altitude.min_m - options_.altitude_tolerance_m ||
      p.z() > options_.limits.altitude.max_m + options_.altitude_tolerance_m)
    return EpisodeOutcome::kAltitudeViolation;
  if ((p - setup_.target_m).norm() <= options_.target_radius_m &&
      std::abs(p.z() - setup_.target_m.z()) <= options_.target_altitude_band_m)
    return EpisodeOutcome::kReached;
  if (time_s_ >= setup_.time_limit_s) return EpisodeOutcome::kTimeout;
  return EpisodeOutcome::kRunning;
}

StepResult UavEnvironment::step(const Vec3& action) {
  require(wind_ != nullptr, "environment", "step() before reset()");
  const EnvironmentOptions& o = options_;
  StepResult out;
  RewardInput ri;
  ri.action = action;
  for (int i = 0; i < 3; ++i)
    ri.action[i] = std::isfinite(action[i]) ? std::clamp(action[i], -1.0, 1.0) : 0.0;
  ri.distance_before_m = (state_.head<3>() - setup_.target_m).norm();
  vehicle::State fix = state_;
  for (int i = 0; i < 3; ++i) fix[i] += o.position_noise_m * noise_.normal();
  const vehicle::Input wanted = action_to_command(ri.action, fix, o.vehicle);
  const int controls =
      std::max(1, static_cast<int>(std::lround(o.action_period_s / o.control_period_s)));
  const int substeps =
      std::max(1, static_cast<int>(std::ceil(o.control_period_s / o.truth_step_s - 1e-9)));
  const double h = o.control_period_s / substeps;
  const Vec3 max_change = o.max_command_rate * o.control_period_s;
  EpisodeOutcome result = EpisodeOutcome::kRunning;
  for (int c = 0; c < controls && result == EpisodeOutcome::kRunning; ++c) {
    // The on-board loop: rate limit towards the policy's command, then eq. 2–3 at the fix.
    vehicle::Input u = command_;
    for (int i = 0; i < 3; ++i)
      u[i] = std::clamp(wanted[i], command_[i] - max_change[i], command_[i] + max_change[i]);
    command_ = vehicle::clamp_to_limits(u, state_, o.vehicle);
    for (int s = 0; s < substeps; ++s) {
      state_ = vehicle::rk4_step(state_, command_, wind_->at(state_.head<3>(), time_s_),
                                 truth_params_, h);
      time_s_ += h;
    }
    const Vec3 measured = anemometer_->measure(*wind_, state_.head<3>(), time_s_);
    wind_estimate_ += o.control_period_s / (o.wind_filter_time_s + o.control_period_s) *
                      (measured - wind_estimate_);
    result = outcome();
  }
  const Vec3 p = state_.head<3>();
  ri.distance_after_m = (p - setup_.target_m).norm();
  ri.clearance_over_safe_m = clearance_over_safe_m(p);
  ri.threat_surface_m = nearest_threat_surface_m(p);
  ri.outcome = result;
  out.reward = compute_reward(ri, o.reward, o.vehicle.cruise_speed_m_s, o.action_period_s,
                              o.limits.threat_margin_m);
  out.outcome = result;
  out.observation = observe();
  return out;
}

}  // namespace ridgeline::learning
