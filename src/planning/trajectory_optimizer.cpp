#include "planning/trajectory_optimizer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <tuple>

#include "core/cpu_clock.hpp"
#include "planning/guess_deconfliction.hpp"
#include "planning/time_parametrization.hpp"
#include "planning/trajectory_ipopt.hpp"
#include "planning/trajectory_nlp.hpp"
#include "planning/priority_decomposition.hpp"
#include "planning/trajectory_team_grid.hpp"

namespace ridgeline::planning {
namespace {

using Clock = std::chrono::steady_clock;
using detail::GridUav;
using detail::Multipliers;
using detail::NlpSetup;
using detail::SeparationCandidate;
using detail::TrajectoryNlp;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string check_options(const TrajectoryOptimizerOptions& o) {
  auto bad = [](const char* field, const char* why) { return fmt::format("options.{}: {}", field, why); };
  auto finite_nonneg = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (o.time_step_s <= 0.0 && o.waypoints_per_uav < 2) return bad("waypoints_per_uav", "must be >= 2");
  if (!std::isfinite(o.time_step_s)) return bad("time_step_s", "must be finite");
  if (!finite_nonneg(o.clearance_margin_m)) return bad("clearance_margin_m", "must be >= 0");
  if (!finite_nonneg(o.separation_margin_m)) return bad("separation_margin_m", "must be >= 0");
  if (!(o.grade_fraction > 0.0 && o.grade_fraction <= 1.0)) return bad("grade_fraction", "must be in (0, 1]");
  if (o.terrain_samples_per_segment < 0) return bad("terrain_samples_per_segment", "must be >= 0");
  if (o.separation_samples_per_step < 0) return bad("separation_samples_per_step", "must be >= 0");
  if (!finite_nonneg(o.separation_prefilter_m)) return bad("separation_prefilter_m", "must be >= 0");
  if (!(o.guess_separation_factor >= 1.0 && std::isfinite(o.guess_separation_factor)))
    return bad("guess_separation_factor", "must be finite and >= 1");
  if (!(o.max_turn_angle_rad > 0.0 && o.max_turn_angle_rad < kPi))
    return bad("max_turn_angle_rad", "must be in (0, pi)");
  for (auto [v, name] : {std::pair{o.pitch_penalty, "pitch_penalty"}, {o.turn_penalty, "turn_penalty"},
                         {o.weight_range, "weight_range"}, {o.weight_pitch, "weight_pitch"},
                         {o.weight_turn, "weight_turn"}, {o.weight_altitude, "weight_altitude"},
                         {o.lambda_individual, "lambda_individual"},
                         {o.lambda_collision, "lambda_collision"}, {o.climb_current, "climb_current"},
                         {o.turn_current, "turn_current"}, {o.speed_current, "speed_current"}})
    if (!finite_nonneg(v)) return bad(name, "must be finite and >= 0");
  if (!(o.collision_soft_distance_m > 0.0 && std::isfinite(o.collision_soft_distance_m)))
    return bad("collision_soft_distance_m", "must be > 0");
  if (!(o.altitude_scale_m > 0.0 && std::isfinite(o.altitude_scale_m)))
    return bad("altitude_scale_m", "must be > 0");
  if (!(o.tolerance > 0.0)) return bad("tolerance", "must be > 0");
  if (!(o.constraint_tolerance > 0.0)) return bad("constraint_tolerance", "must be > 0");
  if (o.max_iterations < 1) return bad("max_iterations", "must be >= 1");
  if (o.iterations_per_uav < 0) return bad("iterations_per_uav", "must be >= 0");
  if (o.max_refinements < 0) return bad("max_refinements", "must be >= 0");
  if (o.uav_max_refinements < 0) return bad("uav_max_refinements", "must be >= 0");
  if (o.max_priority_swaps < 0) return bad("max_priority_swaps", "must be >= 0");
  if (!(o.time_budget_s > 0.0)) return bad("time_budget_s", "must be > 0");
  if (o.lbfgs_history < 1) return bad("lbfgs_history", "must be >= 1");
  if (o.joint_max_uavs < 1) return bad("joint_max_uavs", "must be >= 1");
  if (o.threads < 1) return bad("threads", "must be >= 1");
  if (!(o.coupling_distance_m > 0.0 && std::isfinite(o.coupling_distance_m)))
    return bad("coupling_distance_m", "must be > 0");
  if (!(o.obstacle_prefilter_m >= 0.0 && std::isfinite(o.obstacle_prefilter_m)))
    return bad("obstacle_prefilter_m", "must be finite and >= 0");
  if (!(o.validation_terrain_step_m > 0.0 && o.validation_terrain_step_m <= 5.0))
    return bad("validation_terrain_step_m", "must be in (0, 5] m");
  if (!(o.validation_separation_period_s > 0.0)) return bad("validation_separation_period_s", "must be > 0");
  return "";
}

std::string check_uav(const TrajectoryUav& u, int i, const world::Terrain& terrain,
                      const world::SafetyLimits& limits) {
  const std::string root = fmt::format("uavs[{}]", i);
  const auto& path = u.initial_path_m;
  if (path.size() < 2) return root + ".initial_path_m: needs at least 2 points";
  for (std::size_t k = 0; k < path.size(); ++k)
    if (!path[k].allFinite()) return fmt::format("{}.initial_path_m[{}]: not finite", root, k);
  const int last = static_cast<int>(path.size()) - 1;
  for (std::size_t m = 0; m < u.target_indices.size(); ++m) {
    const int t = u.target_indices[m];
    if (t <= 0 || t > last || (m > 0 && t <= u.target_indices[m - 1]))
      return fmt::format("{}.target_indices[{}]: {} must be in (0, {}] and increasing", root, m, t, last);
  }
  if (!u.target_indices.empty() && u.target_indices.back() != last)
    return fmt::format("{}.target_indices: the last target must be the path's last point ({})", root, last);
  const auto& v = u.vehicle;
  if (!(v.cruise_speed_m_s > 0.0 && std::isfinite(v.cruise_speed_m_s)))
    return root + ".vehicle.cruise_speed_m_s: must be > 0";
  if (!(v.speed_band_m_s >= 0.0 && v.speed_band_m_s < v.cruise_speed_m_s))
    return root + ".vehicle.speed_band_m_s: must be in [0, cruise speed)";
  if (!(v.max_climb_rate_m_s > 0.0 && std::isfinite(v.max_climb_rate_m_s)))
    return root + ".vehicle.max_climb_rate_m_s: must be > 0";
  if (!(v.max_pitch_rad > 0.0 && v.max_pitch_rad < kPi / 2))
    return root + ".vehicle.max_pitch_rad: must be in (0, pi/2)";
  // The start and the targets are fixed waypoints: they must satisfy eq. 14 and 19–20 themselves.
  std::vector<int> fixed = {0};
  fixed.insert(fixed.end(), u.target_indices.begin(), u.target_indices.end());
  if (u.target_indices.empty()) fixed.push_back(last);
  const double floor_m = limits.clearance_floor_m(terrain);
  for (int k : fixed) {
    const Vec3& p = path[k];
    const std::string what = k == 0 ? "start" : "target";
    if (!limits.altitude.contains(p.z()))
      return fmt::format(
          "{}.initial_path_m[{}]: {} altitude {:.1f} m outside [{:.1f}, {:.1f}] m (eq. 14)", root,
          k, what, p.z(), limits.altitude.min_m, limits.altitude.max_m);
    const double clearance = p.z() - terrain.height(p.x(), p.y());
    if (clearance < floor_m)
      return fmt::format("{}.initial_path_m[{}]: {} is {:.2f} m above the terrain, below the "
                         "required {:.2f} m (eq. 19-20)",
                         root, k, what, clearance, floor_m);
  }
  return "";
}

// Cruise time of each initial segment: max(ℓ/v0, |Δz|/w_max).
double segment_time(const Vec3& a, const Vec3& b, const vehicle::VehicleParams& v, bool climb) {
  const double t_h = (b - a).head<2>().norm() / v.cruise_speed_m_s;
  const double t_z = climb ? std::abs(b.z() - a.z()) / v.max_climb_rate_m_s : 0.0;
  return std::max(t_h, t_z);
}

struct Legs {
  std::vector<int> ends;        // index into the path of each leg's end (targets)
  std::vector<double> times_s;  // cruise time of each leg
};

Legs legs_of(const TrajectoryUav& u, bool climb) {
  Legs legs;
  legs.ends = u.target_indices;
  if (legs.ends.empty()) legs.ends.push_back(static_cast<int>(u.initial_path_m.size()) - 1);
  int begin = 0;
  for (int end : legs.ends) {
    double t = 0.0;
    for (int k = begin; k < end; ++k)
      t += segment_time(u.initial_path_m[k], u.initial_path_m[k + 1], u.vehicle, climb);
    legs.times_s.push_back(t);
    begin = end;
  }
  return legs;
}

// UAV u on the grid of step dt: each leg resampled at equal times (file comment of the header).
GridUav make_grid(const TrajectoryUav& u, const Legs& legs, double dt, bool climb,
                  double grade_fraction) {
  GridUav g;
  g.name = u.name;
  const auto& v = u.vehicle;
  g.nominal_length_m = v.cruise_speed_m_s * dt;
  g.max_length_m = v.max_speed_m_s() * dt;
  g.max_climb_m = v.max_climb_rate_m_s * dt;
  g.tan_max_pitch = std::tan(v.max_pitch_rad);
  // Flown at pitch atan(grade) ≤ θ_max, and at v0 − Δv or faster climbing ≤ w_max (eq. 2).
  g.max_grade = grade_fraction *
                std::min(g.tan_max_pitch, v.max_climb_rate_m_s / v.min_speed_m_s());
  g.pitch_rows = !(climb && g.max_climb_m <= g.tan_max_pitch * g.nominal_length_m);
  g.guess_m.push_back(u.initial_path_m.front());
  g.fixed.push_back(1);
  int begin = 0;
  for (std::size_t leg = 0; leg < legs.ends.size(); ++leg) {
    const int end = legs.ends[leg];
    const double t_leg = legs.times_s[leg];
    // Round to the grid, but never so few segments that the guess exceeds v0 + Δv.
    int n = std::max(1, static_cast<int>(std::lround(t_leg / dt)));
    n = std::max(n, static_cast<int>(std::ceil(t_leg * v.cruise_speed_m_s / (v.max_speed_m_s() * dt) - 1e-9)));
    int k = begin;
    double t_k = 0.0;  // cruise time at path point k
    for (int j = 1; j <= n; ++j) {
      if (j == n) {
        g.guess_m.push_back(u.initial_path_m[end]);
        g.fixed.push_back(1);
        break;
      }
      const double t = t_leg * j / n;
      double t_seg = segment_time(u.initial_path_m[k], u.initial_path_m[k + 1], v, climb);
      while (k + 1 < end && t_k + t_seg < t) {
        t_k += t_seg;
        ++k;
        t_seg = segment_time(u.initial_path_m[k], u.initial_path_m[k + 1], v, climb);
      }
      const double s = t_seg > 0.0 ? std::clamp((t - t_k) / t_seg, 0.0, 1.0) : 0.0;
      g.guess_m.push_back(u.initial_path_m[k] + s * (u.initial_path_m[k + 1] - u.initial_path_m[k]));
      g.fixed.push_back(0);
    }
    begin = end;
  }
  for (int k = 0; k < g.segments(); ++k) {
    const double guess = (g.guess_m[k + 1] - g.guess_m[k]).head<2>().norm();
    g.min_length_m.push_back(std::min(v.min_speed_m_s() * dt, 0.5 * guess));
  }
  return g;
}

Vec3 held(const GridUav& u, int k) { return u.guess_m[std::min(k, u.segments())]; }
bool held_fixed(const GridUav& u, int k) { return u.fixed[std::min(k, u.segments())] != 0; }

}  // namespace

namespace detail {

std::vector<TimedPath> timed_paths(const std::vector<GridUav>& grid,
                                   const std::vector<std::vector<Vec3>>& waypoints, double dt) {
  std::vector<TimedPath> out(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    out[i].name = grid[i].name;
    out[i].waypoints_m = waypoints[i];
    for (std::size_t k = 0; k < waypoints[i].size(); ++k) out[i].times_s.push_back(k * dt);
  }
  return out;
}

// The problem's and options' errors (the first found), or empty.
std::string check_problem(const TrajectoryProblem& problem,
                          const TrajectoryOptimizerOptions& options) {
  if (problem.terrain == nullptr) return "problem.terrain: missing";
  if (problem.uavs.empty()) return "problem.uavs: empty";
  if (std::string e = check_options(options); !e.empty()) return e;
  try {
    world::validate(problem.limits);
  } catch (const InputError& e) {
    return fmt::format("problem.limits: {}", e.what());
  }
  for (std::size_t i = 0; i < problem.uavs.size(); ++i)
    if (std::string e =
            check_uav(problem.uavs[i], static_cast<int>(i), *problem.terrain, problem.limits);
        !e.empty())
      return e;
  return {};
}


TeamGrid make_team_grid(const TrajectoryProblem& problem,
                        const TrajectoryOptimizerOptions& options) {
  const bool climb = options.enforce_climb_rate;
  const int n_uav = static_cast<int>(problem.uavs.size());
  TeamGrid team;
  std::vector<Legs> legs;
  double t_max = 0.0;
  for (int i = 0; i < n_uav; ++i) {
    legs.push_back(legs_of(problem.uavs[i], climb));
    double t = 0.0;
    for (std::size_t m = 0; m < legs[i].times_s.size(); ++m) {
      if (!(legs[i].times_s[m] > 0.0)) {
        team.error = fmt::format(
            "uavs[{}].target_indices[{}]: the target coincides with the previous point of the "
            "route",
            i, m);
        return team;
      }
      t += legs[i].times_s[m];
    }
    t_max = std::max(t_max, t);
  }
  team.dt = options.time_step_s > 0.0 ? options.time_step_s : t_max / options.waypoints_per_uav;
  for (int i = 0; i < n_uav; ++i) {
    team.uavs.push_back(
        make_grid(problem.uavs[i], legs[i], team.dt, climb, options.grade_fraction));
    team.max_index = std::max(team.max_index, team.uavs[i].segments());
  }
  return team;
}

// Separation-aware guesses (guess_deconfliction.hpp): altitude layers where the independent
// initial paths meet at equal times, so Ipopt starts apart instead of pulling UAVs apart.
// Without deconfliction, only the guesses' separation is measured.
GuessDeconflictionSummary deconflict_team(const TrajectoryProblem& problem,
                                          const TrajectoryOptimizerOptions& options,
                                          TeamGrid& team) {
  const world::SafetyLimits& limits = problem.limits;
  const bool climb = options.enforce_climb_rate;
  std::vector<GuessUav> guesses;
  GuessDeconflictionSummary report;
  if (!options.deconflict_guesses) {
    for (const GridUav& g : team.uavs) guesses.push_back({g.guess_m, g.fixed, 1.0, 0.5});
    report.min_separation_before_m = min_guess_separation(
        guesses, options.guess_separation_factor * limits.separation_m, &report.conflicts_before);
    report.min_separation_after_m = report.min_separation_before_m;
    report.conflicts_after = report.conflicts_before;
    return report;
  }
  // A lift's ramp uses what the guess leaves of the climb limit (when it is a row) and of the
  // pitch limit at cruise.
  for (std::size_t i = 0; i < team.uavs.size(); ++i) {
    const GridUav& g = team.uavs[i];
    const vehicle::VehicleParams& v = problem.uavs[i].vehicle;
    const double pitch_step_m = g.tan_max_pitch * g.nominal_length_m;
    guesses.push_back(
        {g.guess_m, g.fixed, climb ? std::min(g.max_climb_m, pitch_step_m) : pitch_step_m,
         std::clamp(v.min_speed_m_s() / v.cruise_speed_m_s, 0.0, 0.95), g.tan_max_pitch});
  }
  GuessDeconflictionOptions deconfliction;
  deconfliction.separation_m = std::max(options.guess_separation_factor * limits.separation_m,
                                        limits.separation_m + options.separation_margin_m);
  report = deconflict_guesses(guesses, limits.altitude, deconfliction);
  for (std::size_t i = 0; i < team.uavs.size(); ++i) {
    GridUav& g = team.uavs[i];
    g.guess_m = guesses[i].guess_m;
    g.fixed = guesses[i].fixed;
    // A delay adds points: the speed band's lower bounds follow the new guess.
    g.min_length_m.clear();
    for (int k = 0; k < g.segments(); ++k) {
      const double guess = (g.guess_m[k + 1] - g.guess_m[k]).head<2>().norm();
      g.min_length_m.push_back(
          std::min(problem.uavs[i].vehicle.min_speed_m_s() * team.dt, 0.5 * guess));
    }
    team.max_index = std::max(team.max_index, g.segments());
  }
  return report;
}

// Points fixed at the same time (starts, targets, finished UAVs holding) must already be
// separated: no optimization can move them (eq. 21). The first pair that is not, or empty.
std::string fixed_points_too_close(const TeamGrid& team, double separation_m) {
  const std::vector<GridUav>& grid = team.uavs;
  for (std::size_t a = 0; a < grid.size(); ++a)
    for (std::size_t b = a + 1; b < grid.size(); ++b)
      for (int k = 0; k <= team.max_index; ++k) {
        if (!held_fixed(grid[a], k) || !held_fixed(grid[b], k)) continue;
        const Vec3 p = held(grid[a], k);
        const Vec3 q = held(grid[b], k);
        const double d = (p - q).norm();
        if (d < separation_m)
          return fmt::format(
              "separation (eq. 21): UAVs {} and {} are both fixed at t = {:.1f} s (start, "
              "target or holding at the final point), at ({:.1f}, {:.1f}, {:.1f}) and ({:.1f}, "
              "{:.1f}, {:.1f}), {:.2f} m apart < d_safe = {:.2f} m",
              grid[a].name, grid[b].name, k * team.dt, p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), d,
              separation_m);
      }
  return {};
}


// Candidate pairs/steps (eq. 21 rows and J_col) from the guesses.
Candidates initial_candidates(const TeamGrid& team, const TrajectoryOptimizerOptions& options) {
  const std::vector<GridUav>& grid = team.uavs;
  const int n_uav = static_cast<int>(grid.size());
  Candidates candidates;
  for (int a = 0; a < n_uav; ++a)
    for (int b = a + 1; b < n_uav; ++b)
      for (int k = 0; k <= team.max_index; ++k) {
        const Vec3 r0 = held(grid[a], k) - held(grid[b], k);
        const Vec3 r1 = held(grid[a], k + 1) - held(grid[b], k + 1);
        const double d = std::min({r0.norm(), r1.norm(), (0.5 * (r0 + r1)).norm()});
        if (d < options.separation_prefilter_m)
          candidates[{a, b, k}] =
              SeparationCandidate{a, b, k, options.separation_samples_per_step, 0.0};
      }
  return candidates;
}

// Refines where the dense check failed: more terrain samples and margin on a violated segment
// and its neighbours, more separation rows and margin around a violated step.
void refine_where_broken(const PlanValidationReport& validation, const TeamGrid& team,
                         const TrajectoryOptimizerOptions& options, NlpSetup& setup,
                         Candidates& candidates) {
  for (const PlanViolation& v : validation.violations) {
    const double extra = v.amount_m + 0.1;
    if (v.kind == ViolationKind::kTerrainClearance) {
      // The violated segment gets more samples and margin; its neighbours get more samples
      // too, since the re-solve may slide the waypoints so the same terrain feature falls on
      // the next segment.
      const int n = team.uavs[v.uav].segments();
      const int k = std::min(v.segment, n - 1);
      for (int kk = std::max(0, k - 1); kk <= std::min(n - 1, k + 1); ++kk) {
        int& samples = setup.terrain_samples[v.uav][kk];
        samples = 2 * samples + 1;
      }
      for (int p : {k, k + 1}) setup.clearance_extra_m[v.uav][p] += extra;
    } else if (v.kind == ViolationKind::kSeparation) {
      const int k = std::clamp(static_cast<int>(std::floor(v.time_s / team.dt)), 0, team.max_index);
      for (int kk : {k - 1, k, k + 1}) {
        if (kk < 0 || kk > team.max_index) continue;
        auto [it, inserted] = candidates.try_emplace(
            std::tuple{v.uav, v.other_uav, kk},
            SeparationCandidate{v.uav, v.other_uav, kk, options.separation_samples_per_step, 0.0});
        it->second.interior_samples = 2 * it->second.interior_samples + 1;
        it->second.margin_m += extra;
      }
    }
    // Altitude violations cannot be refined: eq. 14 is a variable bound and z is linear on a
    // segment. They can only come from Ipopt's bound relaxation and are reported as such.
  }
}


// The solution as stage 4 of the global planner will fly it (time_parametrize_timed): the UAVs
// with a pitch or climb-rate violation, each with its largest excess, and the dense check of the
// flown references themselves (their rounded corners and timing errors move them off the
// waypoints' straight, linearly timed segments), each violation placed on the grid step of its
// time, where refine_where_broken adds rows.

FlownCheck check_flown(const TrajectoryProblem& problem, const std::vector<TimedPath>& paths,
                       const TrajectoryOptimizerOptions& options, const TeamGrid& team,
                       const PlanValidationOptions& validation) {
  FlownCheck out;
  std::vector<TimedPath> flown(paths.size());
  for (std::size_t i = 0; i < paths.size(); ++i) {
    const vehicle::VehicleParams& v = problem.uavs[i].vehicle;
    const TimeParametrizationResult& r = out.timing.emplace_back(
        time_parametrize_timed(paths[i].waypoints_m, paths[i].times_s, v, options.timing));
    flown[i].name = paths[i].name;
    if (r.samples.empty()) {
      flown[i] = paths[i];  // no reference (invalid input): stage 4 reports it
    } else {
      flown[i].times_s = r.sample_times_s;
      for (const auto& sample : r.samples) flown[i].waypoints_m.push_back(sample.position_m);
    }
    GradeExcess excess{static_cast<int>(i), 1.0, {}};
    for (const LimitViolation& violation : r.violations) {
      double ratio = 1.0;
      if (violation.kind == LimitKind::kPitch)
        ratio = std::tan(std::min(violation.value, 0.5 * kPi - 1e-6)) / std::tan(violation.limit);
      else if (violation.kind == LimitKind::kClimbRate)
        ratio = violation.value / violation.limit;
      if (ratio > excess.ratio) {
        excess.ratio = ratio;
        excess.description = fmt::format("{}: {} (t = {:.1f} s)", paths[i].name,
                                          violation.description, violation.t_begin_s);
      }
    }
    if (excess.ratio > 1.0) out.steep.push_back(std::move(excess));
  }
  try {
    out.validation = validate_plan(*problem.terrain, flown, problem.limits, validation);
  } catch (const InputError&) {
    return out;  // samples not strictly increasing in time: stage 4 and 5 judge the references
  }
  // The references' samples are 0.02 s apart: many violations fall on one grid step, and
  // refine_where_broken doubles a step's samples per violation. One per kind, UAV(s) and step,
  // the worst.
  std::map<std::tuple<int, int, int, int>, PlanViolation> worst;
  for (PlanViolation& v : out.validation.violations) {
    const int k = static_cast<int>(std::floor(v.time_s / team.dt));
    v.segment = std::clamp(k, 0, team.uavs[v.uav].segments() - 1);
    auto [it, inserted] =
        worst.try_emplace({static_cast<int>(v.kind), v.uav, v.other_uav, v.segment}, v);
    if (!inserted && v.amount_m > it->second.amount_m) it->second = v;
  }
  out.validation.violations.clear();
  for (auto& [key, v] : worst) out.validation.violations.push_back(std::move(v));
  return out;
}

Multipliers warm_start(const TrajectoryNlp& nlp, const Multipliers& previous_bounds,
                       const std::map<TrajectoryNlp::RowKey, double>& previous_lambda) {
  Multipliers warm;
  if (previous_bounds.z_lower.size() != static_cast<std::size_t>(nlp.num_variables())) return warm;
  warm.z_lower = previous_bounds.z_lower;
  warm.z_upper = previous_bounds.z_upper;
  warm.lambda.assign(nlp.num_constraints(), 0.0);
  for (int r = 0; r < nlp.num_constraints(); ++r)
    if (auto it = previous_lambda.find(nlp.row_key(r)); it != previous_lambda.end())
      warm.lambda[r] = it->second;
  return warm;
}

// A UAV whose grades cannot be flown gets the hard grade row on every segment (where one segment
// is bounded, the solve would move the climb to its unbounded neighbours); if it had them, its G
// shrinks by the excess, 1 % more: what its corners added (time_parametrization.hpp) was more
// than grade_fraction left for them.
void bound_grades(const std::vector<GradeExcess>& excesses, NlpSetup& setup) {
  if (setup.grade_rows.empty())
    for (const GridUav& g : setup.uavs) setup.grade_rows.emplace_back(g.segments(), 0);
  for (const GradeExcess& e : excesses) {
    std::vector<char>& rows = setup.grade_rows[e.uav];
    if (std::find(rows.begin(), rows.end(), 1) != rows.end())
      setup.uavs[e.uav].max_grade /= 1.01 * e.ratio;
    std::fill(rows.begin(), rows.end(), 1);
  }
}

// When the dense check found a separation violation, the pairs the solution brought within
// the collision cost's reach D_c (or the prefilter distance, if smaller) that are not
// candidates yet become candidates too: the solve moved them away from their guesses, and
// without rows they would be found one violation a round (10 UAVs × 100 waypoints: 4 rounds
// and the time budget before, 2 rounds after).
void add_candidates_the_solve_brought_near(const PlanValidationReport& validation,
                                           const std::vector<std::vector<Vec3>>& waypoints,
                                           const TeamGrid& team, double separation_m,
                                           const TrajectoryOptimizerOptions& options,
                                           Candidates& candidates) {
  bool separation_violated = false;
  for (const PlanViolation& v : validation.violations)
    separation_violated = separation_violated || v.kind == ViolationKind::kSeparation;
  const double near_m = separation_violated ? std::min(options.separation_prefilter_m,
                                                       options.collision_soft_distance_m)
                                            : 0.0;
  const int n_uav = static_cast<int>(team.uavs.size());
  for (int a = 0; a < n_uav; ++a)
    for (int b = a + 1; b < n_uav; ++b)
      for (int k = 0; k <= team.max_index; ++k) {
        if (candidates.count({a, b, k}) != 0) continue;
        // A row that would start violated (within d_safe + margin) is left to the dense
        // check: an infeasible new row at a warm start cost Ipopt hundreds of iterations.
        const double d = step_min_distance(waypoints[a], waypoints[b], k);
        if (d < near_m && d > separation_m + options.separation_margin_m + 1.0)
          candidates[{a, b, k}] =
              SeparationCandidate{a, b, k, options.separation_samples_per_step, 0.0};
      }
}

}  // namespace detail

using detail::add_candidates_the_solve_brought_near;
using detail::bound_grades;
using detail::Candidates;
using detail::check_flown;
using detail::check_problem;
using detail::deconflict_team;
using detail::fixed_points_too_close;
using detail::FlownCheck;
using detail::GradeExcess;
using detail::initial_candidates;
using detail::make_team_grid;
using detail::refine_where_broken;
using detail::TeamGrid;
using detail::timed_paths;

std::string_view to_string(TrajectoryStatus status) {
  switch (status) {
    case TrajectoryStatus::kSolved: return "solved";
    case TrajectoryStatus::kSolvedAfterRefinement: return "solved after refinement";
    case TrajectoryStatus::kInfeasible: return "infeasible";
    case TrajectoryStatus::kIterationLimit: return "iteration limit";
    case TrajectoryStatus::kTimeLimit: return "time limit";
    case TrajectoryStatus::kInvalidInput: return "invalid input";
    case TrajectoryStatus::kValidationFailed: return "validation failed";
    case TrajectoryStatus::kSolverError: return "solver error";
  }
  return "unknown";
}

TrajectoryResult optimize_trajectories(const TrajectoryProblem& problem,
                                       const TrajectoryOptimizerOptions& options) {
  const auto t_start = Clock::now();
  // The budget is CPU time (core/cpu_clock.hpp): a loaded machine gives the same plan.
  CpuBudget budget(options.time_budget_s);
  CpuMeter meter(budget);
  TrajectoryResult result;
  auto fail = [&](TrajectoryStatus status, std::string message) {
    result.status = status;
    result.message = std::move(message);
    result.paths.clear();
    result.timing.clear();
    result.costs.clear();
    result.total_time_s = seconds_since(t_start);
    return result;
  };

  if (std::string e = check_problem(problem, options); !e.empty())
    return fail(TrajectoryStatus::kInvalidInput, e);
  const world::SafetyLimits& limits = problem.limits;
  const world::Terrain& terrain = *problem.terrain;
  const int n_uav = static_cast<int>(problem.uavs.size());

  // Shared time grid and initial guesses.
  TeamGrid team = make_team_grid(problem, options);
  if (!team.error.empty()) return fail(TrajectoryStatus::kInvalidInput, team.error);
  const double dt = team.dt;
  result.time_step_s = dt;
  const bool decompose =
      options.decomposition == TeamDecomposition::kPriority ||
      (options.decomposition == TeamDecomposition::kAuto && n_uav > options.joint_max_uavs);
  if (n_uav > 1) {
    // The decomposition always starts from deconflicted guesses: a UAV whose guess runs through
    // a fixed earlier UAV at the same time starts its NLP deep inside an obstacle row (30 × 200
    // on a generated team: a local infeasibility without, planned with).
    TrajectoryOptimizerOptions guess_options = options;
    guess_options.deconflict_guesses = options.deconflict_guesses || decompose;
    result.guess = deconflict_team(problem, guess_options, team);
  }
  if (std::string e = fixed_points_too_close(team, limits.separation_m); !e.empty())
    return fail(TrajectoryStatus::kInfeasible, e);
  if (decompose)
    return detail::optimize_in_priority_order(problem, options, team, std::move(result), t_start,
                                              budget);
  Candidates candidates = initial_candidates(team, options);

  NlpSetup setup;
  setup.terrain = problem.optimization_terrain != nullptr ? problem.optimization_terrain : &terrain;
  setup.uavs = team.uavs;
  setup.time_step_s = dt;
  setup.limits = limits;
  setup.options = options;
  for (const GridUav& g : team.uavs) {
    setup.terrain_samples.emplace_back(g.segments(), options.terrain_samples_per_segment);
    setup.clearance_extra_m.emplace_back(g.guess_m.size(), 0.0);
  }

  PlanValidationOptions validation;
  validation.terrain_step_m = options.validation_terrain_step_m;
  validation.separation_period_s = options.validation_separation_period_s;

  TrajectoryOptimizerOptions solve_options = options;
  solve_options.max_iterations =
      std::max(options.max_iterations, options.iterations_per_uav * n_uav);

  // Solve, check densely, refine where the check failed, solve again from the last solution.
  std::vector<std::vector<Vec3>> previous;
  std::map<TrajectoryNlp::RowKey, double> previous_lambda;  // by row, from the last solve
  std::string last_flown;  // what the last solution's flown references broke
  Multipliers previous_bounds;                              // variables do not change
  for (int round = 0; round <= options.max_refinements; ++round) {
    setup.candidates.clear();
    for (const auto& [key, c] : candidates) setup.candidates.push_back(c);
    const TrajectoryNlp nlp(setup);
    result.variables = nlp.num_variables();
    result.constraints = nlp.num_constraints();
    result.separation_rows = nlp.separation_rows();

    std::vector<double> x0(nlp.num_variables());
    Multipliers warm;
    if (previous.empty()) {
      nlp.initial_point(x0.data());
      result.initial_costs = nlp.costs(x0.data(), &result.initial_collision_cost);
      result.initial_objective = nlp.objective(x0.data());
    } else {
      nlp.pack(previous, x0.data());
      if (options.warm_start_refinements)
        warm = detail::warm_start(nlp, previous_bounds, previous_lambda);
    }
    const double remaining_s = meter.remaining_s();
    if (remaining_s <= 0.0)
      return fail(TrajectoryStatus::kTimeLimit,
                  fmt::format("time budget of {:.1f} s CPU exhausted after {} solve(s)",
                              options.time_budget_s, result.solves));

    const detail::IpoptSolve solve =
        detail::solve_with_ipopt(nlp, std::move(x0), warm, solve_options, remaining_s);
    result.solve_time_s += solve.solve_time_s;
    ++result.solves;
    result.ipopt_iterations += solve.iterations;

    const std::vector<double>& x = solve.x;
    const std::vector<std::vector<Vec3>> waypoints = nlp.unpack(x.data());
    std::vector<TimedPath> paths = timed_paths(team.uavs, waypoints, dt);
    result.validation = validate_plan(terrain, paths, limits, validation);

    const TrajectoryStatus ipopt_status = solve.status;
    if (ipopt_status != TrajectoryStatus::kSolved) {
      std::string where = nlp.worst_rows(x.data(), 3);
      if (!result.validation.passed())
        where += "; dense check: " + result.validation.violations.front().description;
      return fail(ipopt_status,
                  fmt::format("Ipopt stopped ({}) in solve {}: {}", to_string(ipopt_status),
                              result.solves, where.empty() ? "no violated row" : where));
    }

    FlownCheck flown = check_flown(problem, paths, options, team, validation);
    const std::vector<GradeExcess>& steep = flown.steep;
    if (result.validation.passed() && flown.validation.passed() && steep.empty()) {
      result.status =
          round == 0 ? TrajectoryStatus::kSolved : TrajectoryStatus::kSolvedAfterRefinement;
      result.paths = std::move(paths);
      result.timing = std::move(flown.timing);
      result.costs = nlp.costs(x.data(), &result.collision_cost);
      result.objective = nlp.objective(x.data());
      result.message.clear();
      result.total_time_s = seconds_since(t_start);
      return result;
    }

    refine_where_broken(result.validation, team, options, setup, candidates);
    refine_where_broken(flown.validation, team, options, setup, candidates);
    bound_grades(steep, setup);
    last_flown = !steep.empty() ? "grade: " + steep.front().description
                                : "flown references: " + flown.validation.summary(3);
    add_candidates_the_solve_brought_near(result.validation, waypoints, team, limits.separation_m,
                                          options, candidates);
    previous = waypoints;
    previous_bounds = solve.multipliers;
    previous_lambda.clear();
    for (int r = 0; r < nlp.num_constraints(); ++r)
      previous_lambda[nlp.row_key(r)] = previous_bounds.lambda[static_cast<std::size_t>(r)];
  }
  std::string message =
      fmt::format("every one of {} solve(s) broke a hard constraint in the dense check; last: {}",
                  result.solves,
                  result.validation.passed() ? last_flown : result.validation.summary(3));
  return fail(TrajectoryStatus::kValidationFailed, message);
}

}  // namespace ridgeline::planning
