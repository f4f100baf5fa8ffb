#include "planning/local_replan.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <utility>

#include "core/cpu_clock.hpp"
#include "core/error.hpp"
#include "planning/trajectory_ipopt.hpp"
#include "planning/trajectory_nlp.hpp"

namespace ridgeline::planning {
namespace {

using Clock = std::chrono::steady_clock;
using detail::GridUav;
using detail::Multipliers;
using detail::NlpSetup;
using detail::ObstacleRow;
using detail::TrajectoryNlp;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

double distance_to_segment(const Vec3& q, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double length2 = ab.squaredNorm();
  if (length2 < 1e-18) return (q - a).norm();
  const double s = std::clamp((q - a).dot(ab) / length2, 0.0, 1.0);
  return (q - (a + s * ab)).norm();
}

// The track of the threat's centre the point at time t must keep clear of: c(s) for
// s ∈ [t − δ, t + δ] ∩ [t_appear, t_vanish] ∩ [w0, w1]; empty when that interval is.
std::optional<std::pair<Vec3, Vec3>> swept_track(const world::Threat& threat, double t,
                                                 double delta, double w0, double w1) {
  const double lo = std::max({threat.appear_s, w0, t - delta});
  const double hi = std::min({threat.vanish_s, w1, t + delta});
  if (lo > hi) return std::nullopt;
  return std::pair{threat.centre_at(lo), threat.centre_at(hi)};
}

// Surface distance |p − track| − R (∞ when the threat has no track at t).
double threat_distance(const world::Threat& threat, const Vec3& p, double t, double delta,
                       double w0, double w1) {
  const auto track = swept_track(threat, t, delta, w0, w1);
  if (!track) return std::numeric_limits<double>::infinity();
  return distance_to_segment(p, track->first, track->second) - threat.radius_m;
}

// p(t) of a piecewise-linear timed path, holding before its start and after its end.
Vec3 path_at(const TimedPath& path, double t) {
  const auto& ts = path.times_s;
  if (t <= ts.front()) return path.waypoints_m.front();
  if (t >= ts.back()) return path.waypoints_m.back();
  const std::size_t k =
      static_cast<std::size_t>(std::upper_bound(ts.begin(), ts.end(), t) - ts.begin());
  const double s = (t - ts[k - 1]) / (ts[k] - ts[k - 1]);
  return path.waypoints_m[k - 1] + s * (path.waypoints_m[k] - path.waypoints_m[k - 1]);
}

std::string check_inputs(const LocalReplanProblem& p, const LocalReplanOptions& o) {
  auto bad = [](const std::string& field, const std::string& why) { return field + ": " + why; };
  if (p.terrain == nullptr) return bad("problem.terrain", "missing");
  if (p.reference == nullptr) return bad("problem.reference", "missing");
  if (!std::isfinite(p.start_time_s)) return bad("problem.start_time_s", "must be finite");
  if (!std::isfinite(p.reference_end_time_s) || !(p.reference_end_time_s > p.start_time_s + 1e-6))
    return bad("problem.reference_end_time_s",
               fmt::format("{} must be finite and after start_time_s = {}", p.reference_end_time_s,
                           p.start_time_s));
  const auto& v = p.vehicle;
  if (!(v.cruise_speed_m_s > 0.0 && std::isfinite(v.cruise_speed_m_s)))
    return bad("problem.vehicle.cruise_speed_m_s", "must be > 0");
  if (!(v.speed_band_m_s >= 0.0 && v.speed_band_m_s < v.cruise_speed_m_s))
    return bad("problem.vehicle.speed_band_m_s", "must be in [0, cruise speed)");
  if (!(v.max_climb_rate_m_s > 0.0 && std::isfinite(v.max_climb_rate_m_s)))
    return bad("problem.vehicle.max_climb_rate_m_s", "must be > 0");
  if (!(v.max_pitch_rad > 0.0 && v.max_pitch_rad < kPi / 2))
    return bad("problem.vehicle.max_pitch_rad", "must be in (0, pi/2)");
  if (!(v.min_turn_radius_m > 0.0 && std::isfinite(v.min_turn_radius_m)))
    return bad("problem.vehicle.min_turn_radius_m", "must be > 0");
  for (std::size_t i = 0; i < p.threats.size(); ++i) {
    try {
      world::validate(p.threats[i], fmt::format("problem.threats[{}]", i));
    } catch (const InputError& e) {
      return e.what();
    }
  }
  for (std::size_t i = 0; i < p.others.size(); ++i) {
    const TimedPath& path = p.others[i];
    const std::string root = fmt::format("problem.others[{}]", i);
    if (path.waypoints_m.empty()) return bad(root + ".waypoints_m", "is empty");
    if (path.times_s.size() != path.waypoints_m.size())
      return bad(root + ".times_s", fmt::format("has {} entries for {} waypoints",
                                                path.times_s.size(), path.waypoints_m.size()));
    for (std::size_t k = 0; k < path.times_s.size(); ++k) {
      if (!path.waypoints_m[k].allFinite())
        return bad(fmt::format("{}.waypoints_m[{}]", root, k), "is not finite");
      if (!std::isfinite(path.times_s[k]) || (k > 0 && !(path.times_s[k] > path.times_s[k - 1])))
        return bad(fmt::format("{}.times_s[{}]", root, k),
                   "must be finite and strictly increasing");
    }
  }
  auto positive = [](double x) { return x > 0.0 && std::isfinite(x); };
  auto nonneg = [](double x) { return x >= 0.0 && std::isfinite(x); };
  if (!positive(o.window_s)) return bad("options.window_s", "must be > 0");
  if (!positive(o.time_step_s)) return bad("options.time_step_s", "must be > 0");
  if (!(o.threat_time_margin_s >= 0.0)) return bad("options.threat_time_margin_s", "must be >= 0");
  if (!nonneg(o.obstacle_margin_m)) return bad("options.obstacle_margin_m", "must be >= 0");
  if (o.obstacle_samples_per_step < 0)
    return bad("options.obstacle_samples_per_step", "must be >= 0");
  if (!nonneg(o.threat_prefilter_m)) return bad("options.threat_prefilter_m", "must be >= 0");
  if (!nonneg(o.separation_prefilter_m))
    return bad("options.separation_prefilter_m", "must be >= 0");
  if (!positive(o.lateral_rate_m_s)) return bad("options.lateral_rate_m_s", "must be > 0");
  try {
    world::validate(p.limits);
  } catch (const InputError& e) {
    return fmt::format("problem.limits: {}", e.what());
  }
  if (o.max_refinements < 0) return bad("options.max_refinements", "must be >= 0");
  if (!positive(o.time_budget_s)) return bad("options.time_budget_s", "must be > 0");
  if (!(o.validation_terrain_step_m > 0.0 && o.validation_terrain_step_m <= 5.0))
    return bad("options.validation_terrain_step_m", "must be in (0, 5] m");
  if (!nonneg(o.speed_tolerance_m_s)) return bad("options.speed_tolerance_m_s", "must be >= 0");
  if (!nonneg(o.climb_headroom_m_s) || !(o.climb_headroom_m_s < p.vehicle.max_climb_rate_m_s))
    return bad("options.climb_headroom_m_s", "must be >= 0 and below the vehicle's climb limit");
  if (!nonneg(o.speed_headroom_m_s) || !(o.speed_headroom_m_s < p.vehicle.speed_band_m_s))
    return bad("options.speed_headroom_m_s", "must be >= 0 and below the vehicle's speed band");
  if (!positive(o.timing.control_period_s))
    return bad("options.timing.control_period_s", "must be > 0");
  return "";
}

// Per grid step j (point j → j + 1): interior samples and extra margin of the obstacle rows.
struct StepRefinement {
  int threat_samples = 0;
  double threat_extra_m = 0.0;
  int separation_samples = 0;
  double separation_extra_m = 0.0;
};

// One dense-check finding on the parametrized reference.
struct Finding {
  enum class Kind { kTerrain, kAltitude, kThreat, kSeparation, kLimit } kind = Kind::kTerrain;
  double time_s = 0.0;
  double amount_m = 0.0;
  std::string description;
};

// The window [t0, t1] and its grid (file comment): point j at t0 + (j − 1)·dt, j = 0 … last;
// points 0, 1 and n + 1 … last are fixed on the old reference.
struct WindowGrid {
  double t0 = 0.0;
  double t1 = 0.0;
  int n = 1;
  double dt = 0.0;
  int last = 0;  ///< index of the last grid point (n + 2 when a point follows t1, else n + 1)

  double time(int j) const { return t0 + (j - 1) * dt; }
  bool fixed(int j) const { return j <= 1 || j >= n + 1; }
};

WindowGrid make_window_grid(const LocalReplanProblem& problem, const LocalReplanOptions& options) {
  WindowGrid g;
  g.t0 = problem.start_time_s;
  g.t1 = std::min(g.t0 + options.window_s, problem.reference_end_time_s);
  g.n = std::max(1, static_cast<int>(std::ceil((g.t1 - g.t0) / options.time_step_s - 1e-9)));
  g.dt = (g.t1 - g.t0) / g.n;
  const bool has_post = g.t1 + g.dt <= problem.reference_end_time_s + 1e-9;
  g.last = has_post ? g.n + 2 : g.n + 1;
  return g;
}

// The old reference over the window, sampled at the control period.
struct ReferenceScreen {
  double length_m = 0.0;
  double min_threat_distance_m = std::numeric_limits<double>::infinity();
  std::string unavoidable;  ///< why no re-plan can help (a fixed end inside a threat), or empty
};

ReferenceScreen screen_reference(const LocalReplanProblem& problem,
                                 const LocalReplanOptions& options, const WindowGrid& g) {
  const mpc::ReferenceTrajectory& reference = *problem.reference;
  const double delta = options.threat_time_margin_s;
  const double r_safe = problem.limits.threat_margin_m;
  const double period = options.timing.control_period_s;
  ReferenceScreen screen;
  Vec3 previous = reference.at(g.t0).position_m;
  for (int m = 0;; ++m) {
    const double t = std::min(g.t0 + m * period, g.t1);
    const Vec3 p = reference.at(t).position_m;
    screen.length_m += (p - previous).norm();
    previous = p;
    for (const world::Threat& th : problem.threats)
      screen.min_threat_distance_m =
          std::min(screen.min_threat_distance_m, threat_distance(th, p, t, delta, g.t0, g.t1));
    if (t >= g.t1) break;
  }
  if (!(screen.min_threat_distance_m < r_safe)) return screen;
  for (const double t : {g.t0, g.t1}) {
    const Vec3 p = reference.at(t).position_m;
    for (std::size_t i = 0; i < problem.threats.size(); ++i) {
      const world::Threat& th = problem.threats[i];
      const double d = threat_distance(th, p, t, delta, g.t0, g.t1);
      if (d < r_safe) {
        screen.unavoidable = fmt::format(
            "threat {} ('{}'): the reference at the window's {} (t = {:.2f} s, "
            "({:.1f}, {:.1f}, {:.1f})) is {:.1f} m from its swept sphere, less "
            "than r_safe = {:.1f} m; the re-planned path must start and end on "
            "the reference (a longer window or a finite threat_time_margin_s "
            "may help)",
            i, th.name, t == g.t0 ? "start" : "end", t, p.x(), p.y(), p.z(), d, r_safe);
        return screen;
      }
    }
  }
  return screen;
}

// The re-plan's one UAV on the window grid: step bounds with the options' headroom.
GridUav make_grid_uav(const LocalReplanProblem& problem, const LocalReplanOptions& options,
                      const WindowGrid& g, const std::vector<Vec3>& old_points) {
  const vehicle::VehicleParams& vehicle = problem.vehicle;
  GridUav grid;
  grid.name = "replan";
  grid.nominal_length_m = vehicle.cruise_speed_m_s * g.dt;
  grid.max_length_m = (vehicle.max_speed_m_s() - options.speed_headroom_m_s) * g.dt;
  grid.max_climb_m = (vehicle.max_climb_rate_m_s - options.climb_headroom_m_s) * g.dt;
  grid.tan_max_pitch = std::tan(vehicle.max_pitch_rad);
  grid.pitch_rows = !(grid.max_climb_m <= grid.tan_max_pitch * grid.nominal_length_m);
  for (int j = 0; j <= g.last; ++j) grid.fixed.push_back(g.fixed(j) ? 1 : 0);
  for (int j = 0; j < g.last; ++j) {
    const double guess = (old_points[j + 1] - old_points[j]).head<2>().norm();
    grid.min_length_m.push_back(
        std::min((vehicle.min_speed_m_s() + options.speed_headroom_m_s) * g.dt, 0.9 * guess));
  }
  return grid;
}

// Warm starts: the old reference shifted sideways out of the threats' swept spheres, the side
// needing the smaller total shift first (the other is tried if Ipopt fails from it).
std::vector<std::vector<Vec3>> warm_starts(const LocalReplanProblem& problem,
                                           const LocalReplanOptions& options, const WindowGrid& g,
                                           const std::vector<Vec3>& old_points) {
  const world::Terrain& terrain = *problem.terrain;
  const world::SafetyLimits& limits = problem.limits;
  const double delta = options.threat_time_margin_s;
  const double r_safe = limits.threat_margin_m;
  const int n = g.n;
  Vec2 along = (old_points[n + 1] - old_points[1]).head<2>();
  if (along.norm() < 1e-6) {
    const double psi = problem.reference->at(g.t0).heading_rad;
    along = Vec2(std::cos(psi), std::sin(psi));
  }
  const Vec2 side = Vec2(-along.y(), along.x()).normalized();
  const double floor_m = limits.clearance_floor_m(terrain);
  auto shifted_guess = [&](double sign) {
    std::vector<double> offset(g.last + 1, 0.0);
    for (const world::Threat& th : problem.threats) {
      const double needed = th.radius_m + r_safe + options.obstacle_margin_m + 5.0;
      for (int j = 2; j <= n; ++j) {
        const auto track = swept_track(th, g.time(j), delta, g.t0, g.t1);
        if (!track) continue;
        double s = 0.0;
        const Vec3 dir(sign * side.x(), sign * side.y(), 0.0);
        while (s < 5000.0 &&
               distance_to_segment(old_points[j] + s * dir, track->first, track->second) < needed)
          s += 2.0;
        if (s > std::abs(offset[j])) offset[j] = sign * s;
      }
    }
    // Spread: |offset| grows and shrinks at most lateral_rate_m_s.
    std::vector<double> spread(g.last + 1, 0.0);
    const double step = options.lateral_rate_m_s * g.dt;
    for (int j = 2; j <= n; ++j)
      for (int i = 2; i <= n; ++i) {
        const double m = std::abs(offset[i]) - step * std::abs(i - j);
        if (m > std::abs(spread[j])) spread[j] = sign * m;
      }

    std::vector<Vec3> guess = old_points;
    for (int j = 2; j <= n; ++j) {
      Vec3& p = guess[j];
      p.head<2>() += spread[j] * side;
      p.z() = std::max(p.z(), terrain.height(p.x(), p.y()) + floor_m + 2.0);
      p.z() = std::clamp(p.z(), limits.altitude.min_m, limits.altitude.max_m);
    }
    double total = 0.0;
    for (double o : spread) total += std::abs(o);
    return std::pair{guess, total};
  };
  auto [guess_left, cost_left] = shifted_guess(1.0);
  auto [guess_right, cost_right] = shifted_guess(-1.0);
  std::vector<std::vector<Vec3>> starts = {guess_left, guess_right};
  if (cost_right < cost_left) std::swap(starts[0], starts[1]);
  return starts;
}

// Obstacle rows at the points and interior samples of every step next to a free point, where
// `points` (the current iterate) comes within the prefilter distances.
std::vector<ObstacleRow> obstacle_rows(const LocalReplanProblem& problem,
                                       const LocalReplanOptions& options, const WindowGrid& g,
                                       const std::vector<StepRefinement>& steps,
                                       const std::vector<Vec3>& points) {
  const double delta = options.threat_time_margin_s;
  const double r_safe = problem.limits.threat_margin_m;
  std::vector<ObstacleRow> rows;
  for (int j = 1; j <= g.n; ++j) {
    const StepRefinement& sr = steps[j];
    for (int pass = 0; pass < 2; ++pass) {
      const bool threat = pass == 0;
      const int samples = threat ? sr.threat_samples : sr.separation_samples;
      for (int m = 0; m <= samples; ++m) {
        const double tau = static_cast<double>(m) / (samples + 1);
        if (m == 0 && g.fixed(j)) continue;
        const double t = g.time(j) + tau * g.dt;
        const Vec3 q = (1.0 - tau) * points[j] + tau * points[j + 1];
        if (threat) {
          for (std::size_t i = 0; i < problem.threats.size(); ++i) {
            const world::Threat& th = problem.threats[i];
            const auto track = swept_track(th, t, delta, g.t0, g.t1);
            if (!track) continue;
            const double d = distance_to_segment(q, track->first, track->second);
            if (d > th.radius_m + r_safe + options.threat_prefilter_m) continue;
            rows.push_back({0, j, tau, track->first, track->second,
                            th.radius_m + r_safe + options.obstacle_margin_m + sr.threat_extra_m,
                            true, static_cast<int>(i)});
          }
        } else {
          for (std::size_t i = 0; i < problem.others.size(); ++i) {
            const Vec3 c = path_at(problem.others[i], t);
            if ((q - c).norm() > options.separation_prefilter_m) continue;
            rows.push_back(
                {0, j, tau, c, c,
                 problem.limits.separation_m + options.obstacle_margin_m + sr.separation_extra_m,
                 false, static_cast<int>(i)});
          }
        }
      }
    }
  }
  return rows;
}

// The solved window's waypoints t0 … t1, time-parametrized and rescaled to end exactly at t1;
// a broken vehicle limit is a finding.
struct TimedWindow {
  std::vector<Vec3> waypoints;
  std::vector<double> times;
  TimeParametrizationResult timing;
  std::vector<Finding> findings;
};

TimedWindow time_window(const LocalReplanProblem& problem, const LocalReplanOptions& options,
                        const WindowGrid& g, const std::vector<Vec3>& points) {
  const vehicle::VehicleParams& vehicle = problem.vehicle;
  const double t0 = g.t0;
  const double t1 = g.t1;
  TimedWindow w;
  w.waypoints.assign(points.begin() + 1, points.begin() + g.n + 2);
  for (int j = 1; j <= g.n + 1; ++j) w.times.push_back(g.time(j));
  TimeParametrizationOptions timing = options.timing;
  timing.initial_speed_m_s = std::clamp(problem.reference->at(t0).speed_m_s,
                                        vehicle.min_speed_m_s() + options.speed_headroom_m_s,
                                        vehicle.max_speed_m_s() - options.speed_headroom_m_s);
  // The timing flies within the band narrowed by the headroom, so that the rescaling below
  // stays inside the vehicle's own band.
  vehicle::VehicleParams timing_vehicle = vehicle;
  timing_vehicle.speed_band_m_s -= options.speed_headroom_m_s;
  timing_vehicle.max_climb_rate_m_s -= options.climb_headroom_m_s;
  w.timing = time_parametrize_timed(w.waypoints, w.times, timing_vehicle, timing);
  TimeParametrizationResult& tp = w.timing;
  if (tp.status == TimeParametrizationStatus::kInvalidInput || tp.sample_times_s.size() < 2) {
    w.findings.push_back({Finding::Kind::kLimit, t0, 0.0, "time parametrization: " + tp.message});
    return w;
  }
  for (const LimitViolation& v : tp.violations)
    w.findings.push_back({Finding::Kind::kLimit, v.t_begin_s, 0.0, v.description});
  if (!w.findings.empty()) return w;
  const double t_end = tp.sample_times_s.back();
  const double scale = (t1 - t0) / (t_end - t0);
  for (std::size_t m = 0; m < tp.sample_times_s.size(); ++m) {
    tp.sample_times_s[m] =
        m + 1 == tp.sample_times_s.size() ? t1 : t0 + (tp.sample_times_s[m] - t0) * scale;
    mpc::ReferencePoint& rp = tp.samples[m];
    rp.speed_m_s /= scale;
    rp.turn_rate_rad_s /= scale;
    rp.climb_rate_m_s /= scale;
    const double tol = options.speed_tolerance_m_s;
    if (rp.speed_m_s < vehicle.min_speed_m_s() - tol ||
        rp.speed_m_s > vehicle.max_speed_m_s() + tol ||
        std::abs(rp.climb_rate_m_s) > vehicle.max_climb_rate_m_s + tol) {
      w.findings.push_back(
          {Finding::Kind::kLimit, tp.sample_times_s[m], 0.0,
           fmt::format("speed band / climb limit (eq. 2) at t = {:.2f} s after timing the "
                       "window to end at t_1: speed {:.2f} m/s, climb {:.2f} m/s",
                       tp.sample_times_s[m], rp.speed_m_s, rp.climb_rate_m_s)});
      break;
    }
  }
  return w;
}

// The dense check of the timed samples: terrain and altitude band, threats, separation.
struct WindowCheck {
  std::vector<Finding> findings;
  double min_threat_distance_m = std::numeric_limits<double>::infinity();
  double min_separation_m = std::numeric_limits<double>::infinity();
  double min_terrain_clearance_m = 0.0;
};

WindowCheck check_window(const LocalReplanProblem& problem, const LocalReplanOptions& options,
                         const WindowGrid& g, const TimeParametrizationResult& tp) {
  const world::SafetyLimits& limits = problem.limits;
  const double delta = options.threat_time_margin_s;
  const double r_safe = limits.threat_margin_m;
  PlanValidationOptions terrain_check;
  terrain_check.terrain_step_m = options.validation_terrain_step_m;
  terrain_check.separation_period_s = options.timing.control_period_s;

  WindowCheck check;
  TimedPath own{"replan", {}, tp.sample_times_s};
  for (const mpc::ReferencePoint& rp : tp.samples) own.waypoints_m.push_back(rp.position_m);
  const PlanValidationReport terrain_report =
      validate_plan(*problem.terrain, {own}, limits, terrain_check);
  check.min_terrain_clearance_m = terrain_report.min_clearance_m;
  for (const PlanViolation& v : terrain_report.violations)
    check.findings.push_back({v.kind == ViolationKind::kTerrainClearance ? Finding::Kind::kTerrain
                                                                         : Finding::Kind::kAltitude,
                              v.time_s, v.amount_m, v.description});
  for (std::size_t m = 0; m < own.times_s.size(); ++m) {
    const double t = own.times_s[m];
    const Vec3& p = own.waypoints_m[m];
    for (std::size_t i = 0; i < problem.threats.size(); ++i) {
      const double d = threat_distance(problem.threats[i], p, t, delta, g.t0, g.t1);
      check.min_threat_distance_m = std::min(check.min_threat_distance_m, d);
      if (d < r_safe - 1e-6)
        check.findings.push_back(
            {Finding::Kind::kThreat, t, r_safe - d,
             fmt::format("threat {} ('{}'): {:.2f} m from its swept sphere < r_safe = "
                         "{:.2f} m at t = {:.2f} s, ({:.1f}, {:.1f}, {:.1f})",
                         i, problem.threats[i].name, d, r_safe, t, p.x(), p.y(), p.z())});
    }
    for (std::size_t i = 0; i < problem.others.size(); ++i) {
      const double d = (p - path_at(problem.others[i], t)).norm();
      check.min_separation_m = std::min(check.min_separation_m, d);
      if (d < limits.separation_m - 1e-6)
        check.findings.push_back(
            {Finding::Kind::kSeparation, t, limits.separation_m - d,
             fmt::format("separation (eq. 21) from '{}': {:.2f} m < d_safe = {:.2f} m at "
                         "t = {:.2f} s, ({:.1f}, {:.1f}, {:.1f})",
                         problem.others[i].name, d, limits.separation_m, t, p.x(), p.y(), p.z())});
    }
  }
  return check;
}

// Refines where the check failed: more samples and more margin at the steps around each
// finding. A step refines once per round and kind, by its worst finding: the check reports every
// violating sample, and doubling the samples per finding would explode. Vehicle limits and the
// altitude band cannot be refined: returns the first such finding's description, else empty.
std::string refine_where_broken(const std::vector<Finding>& findings, const WindowGrid& g,
                                NlpSetup& setup, std::vector<StepRefinement>& steps) {
  const int n = g.n;
  std::vector<std::array<double, 3>> worst(static_cast<std::size_t>(n + 1), {-1.0, -1.0, -1.0});
  for (const Finding& f : findings) {
    if (f.kind == Finding::Kind::kLimit || f.kind == Finding::Kind::kAltitude) return f.description;
    const int j = std::clamp(static_cast<int>(std::floor((f.time_s - g.t0) / g.dt)) + 1, 1, n);
    const int kind = f.kind == Finding::Kind::kTerrain  ? 0
                     : f.kind == Finding::Kind::kThreat ? 1
                                                        : 2;
    worst[j][kind] = std::max(worst[j][kind], f.amount_m);
  }
  std::vector<std::array<bool, 3>> refine(static_cast<std::size_t>(n + 1), {false, false, false});
  for (int j = 1; j <= n; ++j)
    for (int kind = 0; kind < 3; ++kind) {
      if (worst[j][kind] < 0.0) continue;
      const double extra = worst[j][kind] + 0.1;
      for (int jj = std::max(1, j - 1); jj <= std::min(n, j + 1); ++jj) refine[jj][kind] = true;
      if (kind == 0) {
        for (int p : {j, j + 1}) setup.clearance_extra_m[0][p] += extra;
      } else if (kind == 1) {
        steps[j].threat_extra_m += extra;
      } else {
        steps[j].separation_extra_m += extra;
      }
    }
  for (int j = 1; j <= n; ++j) {
    if (refine[j][0]) setup.terrain_samples[0][j] = 2 * setup.terrain_samples[0][j] + 1;
    if (refine[j][1]) steps[j].threat_samples = 2 * steps[j].threat_samples + 1;
    if (refine[j][2]) steps[j].separation_samples = 2 * steps[j].separation_samples + 1;
  }
  return {};
}

LocalReplanStatus failure_status(TrajectoryStatus status) {
  switch (status) {
    case TrajectoryStatus::kInfeasible:
      return LocalReplanStatus::kThreatUnavoidable;
    case TrajectoryStatus::kIterationLimit:
      return LocalReplanStatus::kIterationLimit;
    case TrajectoryStatus::kTimeLimit:
      return LocalReplanStatus::kTimeLimit;
    default:
      return LocalReplanStatus::kSolverError;
  }
}

}  // namespace

std::string_view to_string(LocalReplanStatus status) {
  switch (status) {
    case LocalReplanStatus::kReplanned:
      return "replanned";
    case LocalReplanStatus::kNoConflict:
      return "no conflict";
    case LocalReplanStatus::kThreatUnavoidable:
      return "threat unavoidable";
    case LocalReplanStatus::kIterationLimit:
      return "iteration limit";
    case LocalReplanStatus::kTimeLimit:
      return "time limit";
    case LocalReplanStatus::kValidationFailed:
      return "validation failed";
    case LocalReplanStatus::kSolverError:
      return "solver error";
    case LocalReplanStatus::kInvalidInput:
      return "invalid input";
  }
  return "unknown";
}

LocalReplanResult replan_locally(const LocalReplanProblem& problem,
                                 const LocalReplanOptions& options) {
  const auto t_start = Clock::now();
  // The budget is this thread's CPU time (file comment of core/cpu_clock.hpp): in a lock-step
  // simulation a re-plan that fits it is the same whatever else the machine runs.
  CpuBudget budget(options.time_budget_s);
  CpuMeter meter(budget);
  LocalReplanResult result;
  auto fail = [&](LocalReplanStatus status, std::string message) {
    result.status = status;
    result.message = std::move(message);
    result.waypoints = TimedPath{};
    result.reference.reset();
    result.sample_times_s.clear();
    result.samples.clear();
    result.total_time_s = seconds_since(t_start);
    return result;
  };
  if (std::string e = check_inputs(problem, options); !e.empty())
    return fail(LocalReplanStatus::kInvalidInput, e);

  const mpc::ReferenceTrajectory& reference = *problem.reference;
  const WindowGrid g = make_window_grid(problem, options);
  result.window_start_s = g.t0;
  result.window_end_s = g.t1;
  result.time_step_s = g.dt;

  // The old reference over the window: no conflict, or a fixed point the threat covers.
  const ReferenceScreen screen = screen_reference(problem, options, g);
  result.old_length_m = screen.length_m;
  result.min_threat_distance_m = screen.min_threat_distance_m;
  if (!(screen.min_threat_distance_m < problem.limits.threat_margin_m)) {
    result.status = LocalReplanStatus::kNoConflict;
    result.total_time_s = seconds_since(t_start);
    return result;
  }
  if (!screen.unavoidable.empty())
    return fail(LocalReplanStatus::kThreatUnavoidable, screen.unavoidable);

  std::vector<Vec3> old_points;
  for (int j = 0; j <= g.last; ++j) old_points.push_back(reference.at(g.time(j)).position_m);
  GridUav grid = make_grid_uav(problem, options, g, old_points);
  const std::vector<std::vector<Vec3>> starts = warm_starts(problem, options, g, old_points);

  TrajectoryOptimizerOptions opt = options.optimizer;
  opt.time_step_s = g.dt;
  // A corner of angle φ rounded at radius k_s·R_min needs k_s·R_min·tan(φ/2) of each
  // neighbouring segment, of which the timing may use half: on a short grid the turn penalty
  // starts where a cruise-length segment leaves no such room (the time parametrization reports
  // a tighter corner as a turn-radius violation, which fails the window).
  opt.max_turn_angle_rad =
      std::min(opt.max_turn_angle_rad, 2.0 * std::atan(0.5 * grid.nominal_length_m /
                                                       (options.timing.turn_radius_safety_factor *
                                                        problem.vehicle.min_turn_radius_m)));

  NlpSetup setup;
  setup.terrain = problem.terrain;
  setup.time_step_s = g.dt;
  setup.limits = problem.limits;
  setup.options = opt;
  setup.terrain_samples.emplace_back(g.last, std::max(0, opt.terrain_samples_per_segment));
  setup.clearance_extra_m.emplace_back(g.last + 1, 0.0);
  std::vector<StepRefinement> steps(g.last, StepRefinement{options.obstacle_samples_per_step, 0.0,
                                                           options.obstacle_samples_per_step, 0.0});

  // Solve, check densely, refine where the check failed, solve again from the last solution.
  std::vector<Vec3> previous;
  std::map<TrajectoryNlp::RowKey, double> previous_lambda;
  Multipliers previous_bounds;
  std::string last_finding;
  int attempt = 0;
  for (int round = 0; round <= options.max_refinements; ++round) {
    const std::vector<Vec3>& current = previous.empty() ? starts[attempt] : previous;
    grid.guess_m = old_points;  // the fixed points; free ones come from x0
    setup.uavs = {grid};
    setup.obstacles = obstacle_rows(problem, options, g, steps, current);
    const TrajectoryNlp nlp(setup);
    result.variables = nlp.num_variables();
    result.constraints = nlp.num_constraints();
    result.obstacle_rows = nlp.obstacle_rows();
    std::vector<double> x0(nlp.num_variables());
    nlp.pack({current}, x0.data());
    Multipliers warm;
    if (!previous.empty() &&
        previous_bounds.z_lower.size() == static_cast<std::size_t>(nlp.num_variables())) {
      warm.z_lower = previous_bounds.z_lower;
      warm.z_upper = previous_bounds.z_upper;
      warm.lambda.assign(nlp.num_constraints(), 0.0);
      for (int r = 0; r < nlp.num_constraints(); ++r)
        if (auto it = previous_lambda.find(nlp.row_key(r)); it != previous_lambda.end())
          warm.lambda[r] = it->second;
    }
    const double remaining_s = meter.remaining_s();
    if (remaining_s <= 0.0)
      return fail(LocalReplanStatus::kTimeLimit,
                  fmt::format("time budget of {:.3f} s CPU exhausted after {} solve(s){}",
                              options.time_budget_s, result.solves,
                              last_finding.empty() ? "" : "; last: " + last_finding));
    const detail::IpoptSolve solve =
        detail::solve_with_ipopt(nlp, std::move(x0), warm, opt, remaining_s);
    result.solve_time_s += solve.solve_time_s;
    result.ipopt_iterations += solve.iterations;
    ++result.solves;
    if (solve.status != TrajectoryStatus::kSolved) {
      if (previous.empty() && attempt == 0) {  // the other side, from scratch
        attempt = 1;
        --round;
        continue;
      }
      const std::string where = nlp.worst_rows(solve.x.data(), 3);
      return fail(failure_status(solve.status),
                  fmt::format("Ipopt stopped ({}) in solve {}: {}", to_string(solve.status),
                              result.solves, where.empty() ? "no violated row" : where));
    }
    const std::vector<Vec3> points = nlp.unpack(solve.x.data()).front();

    TimedWindow window = time_window(problem, options, g, points);
    std::vector<Finding> findings = std::move(window.findings);
    WindowCheck check;
    if (findings.empty()) {
      check = check_window(problem, options, g, window.timing);
      findings = std::move(check.findings);
    }
    if (findings.empty()) {
      const TimeParametrizationResult& tp = window.timing;
      result.status = LocalReplanStatus::kReplanned;
      result.message.clear();
      result.waypoints = TimedPath{"replan", window.waypoints, window.times};
      result.min_threat_distance_m = check.min_threat_distance_m;
      result.min_separation_m = check.min_separation_m;
      result.min_terrain_clearance_m = check.min_terrain_clearance_m;
      result.join_gap_m = (tp.samples.back().position_m - reference.at(g.t1).position_m).norm();
      result.length_m = 0.0;
      for (std::size_t m = 1; m < tp.samples.size(); ++m)
        result.length_m += (tp.samples[m].position_m - tp.samples[m - 1].position_m).norm();
      result.sample_times_s = tp.sample_times_s;
      result.samples = tp.samples;
      result.reference.emplace(tp.sample_times_s, tp.samples);
      result.total_time_s = seconds_since(t_start);
      return result;
    }
    last_finding = findings.front().description;
    if (const std::string limit = refine_where_broken(findings, g, setup, steps); !limit.empty())
      return fail(LocalReplanStatus::kValidationFailed,
                  fmt::format("the re-planned window breaks a limit: {}", limit));
    previous = points;
    previous_bounds = solve.multipliers;
    previous_lambda.clear();
    for (int r = 0; r < nlp.num_constraints(); ++r)
      previous_lambda[nlp.row_key(r)] = previous_bounds.lambda[static_cast<std::size_t>(r)];
  }
  return fail(
      LocalReplanStatus::kValidationFailed,
      fmt::format("every one of {} solve(s) broke a hard constraint in the dense check; last: {}",
                  result.solves, last_finding));
}

}  // namespace ridgeline::planning
