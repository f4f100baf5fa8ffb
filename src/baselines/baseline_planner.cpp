#include "baselines/baseline_planner.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>

#include "core/error.hpp"
#include "planning/plan_validation.hpp"

namespace ridgeline::baselines {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kDirections = 8;
constexpr int kNoDirection = 8;
constexpr int kDr[kDirections] = {0, 1, 1, 1, 0, -1, -1, -1};
constexpr int kDc[kDirections] = {1, 1, 0, -1, -1, -1, 0, 1};

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// The cost of flying a straight horizontal piece from a to b with heading change `turn_rad`
/// before it, for one baseline (file comment). z_a, z_b: the grid's required altitudes.
class LegCost {
 public:
  LegCost(const BaselinePlannerOptions& o, double cruise_m_s) : o_(o), v0_(cruise_m_s) {}

  double operator()(const Vec2& a, const Vec2& b, double z_a, double z_b, double turn_rad) const {
    const double L = (b - a).norm();
    const double dz = z_b - z_a;
    const double ell = std::sqrt(L * L + dz * dz);
    const double turn = std::abs(turn_rad);
    if (o_.method == BaselinePathMethod::kImprovedAStar)
      return ell + o_.climb_penalty * std::max(0.0, dz) + o_.turn_penalty_m * turn;
    if (L < 1e-9) return o_.weight_load * turn;
    const Vec2 d = (b - a) / L;
    const Vec2 w = o_.forecast_wind_m_s.head<2>();
    const double along = w.dot(d);
    const double cross = w.x() * d.y() - w.y() * d.x();
    const double air = std::sqrt(std::max(1e-6, v0_ * v0_ - cross * cross));
    const double ground = std::max(0.5, along + air);
    const double t = ell / ground;
    const double k_wind = 1.0 + o_.wind_influence * std::max(0.0, -along) / v0_;
    const double energy = k_wind * t + o_.climb_energy_s_per_m * std::max(0.0, dz);
    const double load = turn + std::abs(dz) / std::max(ell, 1e-9);
    return o_.weight_time * t + o_.weight_energy * energy + o_.weight_load * load;
  }

  /// A lower bound of the cost from a to b (A* heuristic).
  double lower_bound(const Vec2& a, const Vec2& b) const {
    const double d = (b - a).norm();
    if (o_.method == BaselinePathMethod::kImprovedAStar) return d;
    const double fastest = v0_ + o_.forecast_wind_m_s.head<2>().norm();
    // Energy is at least the time at k_W = 1.
    return (o_.weight_time + o_.weight_energy) * d / fastest;
  }

 private:
  const BaselinePlannerOptions& o_;
  double v0_;
};

/// Cost of a straight segment, traced through the grid every half cell; kInf if it crosses
/// a blocked cell (the start and goal cells excepted).
double segment_cost(const planning::ClearanceGrid& grid, const LegCost& cost, const Vec2& a,
                    const Vec2& b, double turn_rad, int free_a, int free_b) {
  const double L = (b - a).norm();
  const int pieces =
      std::max(1, static_cast<int>(std::ceil(L / (0.5 * grid.options().cell_size_m))));
  double total = 0.0;
  Vec2 prev = a;
  int prev_cell = grid.cell_of(a.x(), a.y());
  double z_prev = grid.required_altitude_m(prev_cell);
  for (int k = 1; k <= pieces; ++k) {
    const Vec2 p = a + (b - a) * (static_cast<double>(k) / pieces);
    const int cell = grid.cell_of(p.x(), p.y());
    if (grid.blocked(cell) && cell != free_a && cell != free_b) return kInf;
    const double z = grid.required_altitude_m(cell);
    total += cost(prev, p, z_prev, z, k == 1 ? turn_rad : 0.0);
    prev = p;
    z_prev = z;
  }
  return total;
}

/// A* over (cell, heading of the arriving move). Returns cell indices start..goal, empty if
/// the goal cannot be reached.
std::vector<int> grid_search(const planning::ClearanceGrid& grid, const LegCost& cost, int start,
                             int goal, int& expanded) {
  const int cells = grid.rows() * grid.cols();
  const int states = cells * (kDirections + 1);
  std::vector<double> g(static_cast<std::size_t>(states), kInf);
  std::vector<int> parent(static_cast<std::size_t>(states), -1);
  std::vector<char> closed(static_cast<std::size_t>(states), 0);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  const Vec2 goal_xy = grid.cell_centre(goal);
  const auto passable = [&](int cell) {
    return !grid.blocked(cell) || cell == start || cell == goal;
  };
  const int s0 = start * (kDirections + 1) + kNoDirection;
  g[static_cast<std::size_t>(s0)] = 0.0;
  open.push({cost.lower_bound(grid.cell_centre(start), goal_xy), s0});
  int found = -1;
  while (!open.empty()) {
    const auto [f, state] = open.top();
    open.pop();
    if (closed[static_cast<std::size_t>(state)]) continue;
    closed[static_cast<std::size_t>(state)] = 1;
    ++expanded;
    const int cell = state / (kDirections + 1);
    const int dir = state % (kDirections + 1);
    if (cell == goal) {
      found = state;
      break;
    }
    const int r = cell / grid.cols(), c = cell % grid.cols();
    const Vec2 xy = grid.cell_centre(cell);
    for (int k = 0; k < kDirections; ++k) {
      const int rr = r + kDr[k], cc = c + kDc[k];
      if (rr < 0 || cc < 0 || rr >= grid.rows() || cc >= grid.cols()) continue;
      const int next = grid.index(rr, cc);
      if (!passable(next)) continue;
      // A diagonal move must not cut a blocked corner.
      if (kDr[k] != 0 && kDc[k] != 0 &&
          (!passable(grid.index(r, cc)) || !passable(grid.index(rr, c))))
        continue;
      const double turn = dir == kNoDirection ? 0.0 : wrap_angle((k - dir) * kPi / 4.0);
      const double step = cost(xy, grid.cell_centre(next), grid.required_altitude_m(cell),
                               grid.required_altitude_m(next), turn);
      const int ns = next * (kDirections + 1) + k;
      const double gn = g[static_cast<std::size_t>(state)] + step;
      if (gn < g[static_cast<std::size_t>(ns)]) {
        g[static_cast<std::size_t>(ns)] = gn;
        parent[static_cast<std::size_t>(ns)] = state;
        open.push({gn + cost.lower_bound(grid.cell_centre(next), goal_xy), ns});
      }
    }
  }
  std::vector<int> cells_out;
  for (int s = found; s >= 0; s = parent[static_cast<std::size_t>(s)])
    cells_out.push_back(s / (kDirections + 1));
  std::reverse(cells_out.begin(), cells_out.end());
  return cells_out;
}

/// Greedy removal of redundant nodes (file comment): keeps the first and last point.
std::vector<Vec2> smooth(const planning::ClearanceGrid& grid, const LegCost& cost,
                         const std::vector<Vec2>& pts, int free_a, int free_b) {
  if (pts.size() <= 2) return pts;
  const int n = static_cast<int>(pts.size());
  // Cost of the original path between nodes, prefix sums (no turn terms: the shortcut is
  // compared on the same footing, and a shortcut only removes turns).
  std::vector<double> prefix(static_cast<std::size_t>(n), 0.0);
  for (int k = 1; k < n; ++k)
    prefix[static_cast<std::size_t>(k)] =
        prefix[static_cast<std::size_t>(k - 1)] +
        segment_cost(grid, cost, pts[static_cast<std::size_t>(k - 1)],
                     pts[static_cast<std::size_t>(k)], 0.0, free_a, free_b);
  std::vector<Vec2> out{pts.front()};
  int i = 0;
  constexpr int kMaxSpan = 80;  // nodes; bounds the quadratic scan
  while (i < n - 1) {
    int best = i + 1;
    for (int j = std::min(n - 1, i + kMaxSpan); j > i + 1; --j) {
      const double c = segment_cost(grid, cost, pts[static_cast<std::size_t>(i)],
                                    pts[static_cast<std::size_t>(j)], 0.0, free_a, free_b);
      if (c <= prefix[static_cast<std::size_t>(j)] - prefix[static_cast<std::size_t>(i)] + 1e-9) {
        best = j;
        break;
      }
    }
    out.push_back(pts[static_cast<std::size_t>(best)]);
    i = best;
  }
  return out;
}

struct Pin {
  double s_m;
  double z_m;
};

/// The altitude profile of the file comment along a horizontal polyline; returns 3-D
/// waypoints every ≤ profile_step_m, the polyline's corners kept exactly. Around a corner of
/// turn φ, the time parametrization rounds the path with an arc whose tangent points lie
/// R·tan(φ/2) from it, so no sample is kept within that distance: the corner and the nearest
/// kept samples take the highest profile value of the zone (flat, above the floor), and the
/// slope limit is restored by raising (never lowering) the kept samples.
std::vector<Vec3> profile(const planning::ClearanceGrid& grid, const std::vector<Vec2>& xy,
                          const std::vector<Pin>& pins, const BaselinePlannerOptions& o,
                          double slope, double hard_clearance_m, double arc_radius_m) {
  std::vector<Vec2> samples;
  std::vector<double> s;
  std::vector<std::size_t> corner_sample;  // per interior vertex of xy
  std::vector<double> corner_zone_m;
  double acc = 0.0;
  samples.push_back(xy.front());
  s.push_back(0.0);
  for (std::size_t k = 1; k < xy.size(); ++k) {
    const double L = (xy[k] - xy[k - 1]).norm();
    if (L < 1e-6) continue;
    const int pieces = std::max(1, static_cast<int>(std::ceil(L / o.profile_step_m)));
    for (int q = 1; q <= pieces; ++q) {
      samples.push_back(xy[k - 1] + (xy[k] - xy[k - 1]) * (static_cast<double>(q) / pieces));
      s.push_back(acc + L * q / pieces);
    }
    acc += L;
    if (k + 1 < xy.size()) {
      const Vec2 d0 = (xy[k] - xy[k - 1]).normalized();
      const Vec2 d1 = (xy[k + 1] - xy[k]).normalized();
      const double phi = std::acos(std::clamp(d0.dot(d1), -1.0, 1.0));
      const double next = (xy[k + 1] - xy[k]).norm();
      corner_sample.push_back(samples.size() - 1);
      // The arc may use at most half of each segment beside it (time_parametrization.hpp),
      // so the nearest kept sample is at least twice the tangent length away.
      corner_zone_m.push_back(std::min(
          2.0 * arc_radius_m * std::tan(std::min(phi, 2.9) / 2.0) + 1.0, 0.5 * std::min(L, next)));
    }
  }
  const std::size_t m = samples.size();
  std::vector<double> z(m);
  for (std::size_t k = 0; k < m; ++k) {
    double cone = kInf;
    for (const Pin& p : pins) cone = std::min(cone, p.z_m + slope * std::abs(s[k] - p.s_m));
    const double hard = std::max(
        grid.limits().altitude.min_m + o.altitude_pad_m,
        grid.terrain().height(samples[k].x(), samples[k].y()) + hard_clearance_m + o.profile_pad_m);
    const int cell = grid.cell_of(samples[k].x(), samples[k].y());
    z[k] = std::max(hard, std::min(grid.required_altitude_m(cell), cone));
    for (const Pin& p : pins)
      if (std::abs(s[k] - p.s_m) < 1e-6) z[k] = std::max(z[k], p.z_m);
  }
  const auto limit_slopes = [&](const std::vector<std::size_t>& idx) {
    for (std::size_t k = 1; k < idx.size(); ++k)
      z[idx[k]] = std::max(z[idx[k]], z[idx[k - 1]] - slope * (s[idx[k]] - s[idx[k - 1]]));
    for (std::size_t k = idx.size() - 1; k-- > 0;)
      z[idx[k]] = std::max(z[idx[k]], z[idx[k + 1]] - slope * (s[idx[k + 1]] - s[idx[k]]));
  };
  std::vector<std::size_t> all(m);
  for (std::size_t k = 0; k < m; ++k) all[k] = k;
  limit_slopes(all);
  // Corner zones: drop the samples inside, flatten corner and nearest kept samples at the max.
  std::vector<char> keep(m, 1);
  for (std::size_t c = 0; c < corner_sample.size(); ++c) {
    const std::size_t kc = corner_sample[c];
    std::size_t lo = kc, hi = kc;
    while (lo > 0 && s[kc] - s[lo] < corner_zone_m[c]) --lo;
    while (hi + 1 < m && s[hi] - s[kc] < corner_zone_m[c]) ++hi;
    double top = 0.0;
    for (std::size_t k = lo; k <= hi; ++k) top = std::max(top, z[k]);
    for (std::size_t k = lo + 1; k < hi; ++k)
      if (k != kc) keep[k] = 0;
    z[lo] = std::max(z[lo], top);
    z[kc] = std::max(z[kc], top);
    z[hi] = std::max(z[hi], top);
  }
  std::vector<std::size_t> kept;
  for (std::size_t k = 0; k < m; ++k)
    if (keep[k]) kept.push_back(k);
  limit_slopes(kept);
  std::vector<Vec3> out;
  for (const std::size_t k : kept) out.emplace_back(samples[k].x(), samples[k].y(), z[k]);
  return out;
}

planning::GlobalPlan fail(planning::GlobalPlan plan, planning::GlobalPlanStatus status,
                          std::string message) {
  plan.status = status;
  plan.message = std::move(message);
  return plan;
}

}  // namespace

std::string_view to_string(BaselinePathMethod method) {
  switch (method) {
    case BaselinePathMethod::kImprovedAStar:
      return "improved A*";
    case BaselinePathMethod::kWindAware:
      return "wind-aware";
  }
  return "unknown";
}

planning::GlobalPlan plan_baseline_mission(const planning::GlobalPlanningProblem& problem,
                                           const BaselinePlannerOptions& options) {
  using namespace planning;
  const auto start = Clock::now();
  GlobalPlan plan;
  plan.path_source = PathSource::kInitialPathsOptimizerOff;
  if (!problem.terrain)
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, "terrain: is required");
  if (problem.uavs.empty())
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, "uavs: none");
  if (!options.forecast_wind_m_s.allFinite())
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, "forecast_wind_m_s: not finite");

  // 1. The same allocation as the proposed planner.
  auto stage = Clock::now();
  plan.allocation =
      allocate_targets(make_allocation_problem(problem, options.cost_estimate), options.allocation);
  plan.allocation_time_s = seconds_since(stage);
  if (plan.allocation.status == AllocationStatus::kInvalidInput)
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, plan.allocation.message);

  // 2. Search, smoothing and profile per UAV.
  stage = Clock::now();
  PathSearchOptions search = options.search;
  std::vector<const PlannerUav*> flying;
  try {
    double min_turn_radius_m = 0.0;
    for (const PlannerUav& u : problem.uavs)
      min_turn_radius_m = std::max(min_turn_radius_m, u.vehicle.min_turn_radius_m);
    search.turn_margin_m = std::max(search.turn_margin_m, min_turn_radius_m);
    const ClearanceGrid grid(*problem.terrain, problem.area, problem.limits, search);
    const double hard_clearance = problem.limits.clearance_floor_m(*problem.terrain);
    for (std::size_t i = 0; i < problem.uavs.size(); ++i) {
      const PlannerUav& u = problem.uavs[i];
      UavPlan uav_plan;
      uav_plan.name = u.name;
      uav_plan.targets = plan.allocation.routes[i];
      if (uav_plan.targets.empty() && !u.end_m) continue;
      // The route's stops: its targets, then its end (return home, a landing point).
      std::vector<AllocationTarget> stops;
      for (const int t : uav_plan.targets)
        stops.push_back(problem.targets[static_cast<std::size_t>(t)]);
      if (u.end_m) stops.push_back({u.name + " end", *u.end_m, 0});
      const LegCost cost(options, u.vehicle.cruise_speed_m_s);
      std::vector<Vec2> polyline{u.start_m.head<2>()};
      std::vector<double> fixed_z{u.start_m.z()};  // per vertex: pinned altitude, or NaN
      Vec3 from = u.start_m;
      for (const AllocationTarget& target : stops) {
        const int a = grid.cell_of(from.x(), from.y());
        const int b = grid.cell_of(target.position_m.x(), target.position_m.y());
        int expanded = 0;
        const std::vector<int> cells = grid_search(grid, cost, a, b, expanded);
        if (cells.empty())
          return fail(
              std::move(plan), GlobalPlanStatus::kUnreachable,
              fmt::format("{}: target '{}' cannot be reached from {}", u.name, target.name,
                          a == grid.cell_of(u.start_m.x(), u.start_m.y()) ? "the start"
                                                                          : "the previous target"));
        // The exact start and target replace their cells' centres.
        std::vector<Vec2> pts;
        for (const int c : cells) pts.push_back(grid.cell_centre(c));
        pts.front() = from.head<2>();
        pts.back() = target.position_m.head<2>();
        if (pts.size() == 1) pts.push_back(target.position_m.head<2>());
        const std::vector<Vec2> leg = smooth(grid, cost, pts, a, b);
        for (std::size_t k = 1; k < leg.size(); ++k) {
          if ((leg[k] - polyline.back()).norm() < 0.05 && k + 1 < leg.size()) continue;
          polyline.push_back(leg[k]);
          fixed_z.push_back(k + 1 == leg.size() ? target.position_m.z() : kNaN);
        }
        from = target.position_m;
      }
      // Room for the corner arcs: a vertex whose adjacent segment is shorter than twice the
      // arc's tangent length R·tan(φ/2) (plus the neighbour's) is removed when the segment that
      // replaces it is passable; the start and targets stay.
      const double arc_radius =
          options.timing.turn_radius_safety_factor * u.vehicle.min_turn_radius_m;
      const auto tangent_m = [&](std::size_t k) {
        if (k == 0 || k + 1 >= polyline.size()) return 0.0;
        const Vec2 d0 = (polyline[k] - polyline[k - 1]).normalized();
        const Vec2 d1 = (polyline[k + 1] - polyline[k]).normalized();
        const double phi = std::acos(std::clamp(d0.dot(d1), -1.0, 1.0));
        return phi > deg_to_rad(150.0) ? 0.0 : 2.0 * arc_radius * std::tan(phi / 2.0) + 1.0;
      };
      for (bool changed = true; changed;) {
        changed = false;
        for (std::size_t k = 1; k + 1 < polyline.size() && !changed; ++k) {
          const double need = tangent_m(k);
          const bool short_before =
              (polyline[k] - polyline[k - 1]).norm() < need + tangent_m(k - 1);
          const bool short_after = (polyline[k + 1] - polyline[k]).norm() < need + tangent_m(k + 1);
          if (!short_before && !short_after) continue;
          // Remove this vertex, or the free neighbour across the short segment.
          for (const std::size_t victim : {k, short_after ? k + 1 : k - 1}) {
            if (victim == 0 || victim + 1 >= polyline.size() || !std::isnan(fixed_z[victim]))
              continue;
            const Vec2 a = polyline[victim - 1], b = polyline[victim + 1];
            if (segment_cost(grid, cost, a, b, 0.0, grid.cell_of(a.x(), a.y()),
                             grid.cell_of(b.x(), b.y())) == kInf)
              continue;
            polyline.erase(polyline.begin() + static_cast<std::ptrdiff_t>(victim));
            fixed_z.erase(fixed_z.begin() + static_cast<std::ptrdiff_t>(victim));
            changed = true;
            break;
          }
        }
      }
      std::vector<Pin> pins;
      double s_acc = 0.0;
      for (std::size_t k = 0; k < polyline.size(); ++k) {
        if (k > 0) s_acc += (polyline[k] - polyline[k - 1]).norm();
        if (!std::isnan(fixed_z[k])) pins.push_back({s_acc, fixed_z[k]});
      }
      const std::vector<Vec2>& clean = polyline;
      const double slope = options.pitch_use * std::tan(u.vehicle.max_pitch_rad);
      uav_plan.waypoints_m = profile(grid, clean, pins, options, slope, hard_clearance, arc_radius);
      plan.uavs.push_back(std::move(uav_plan));
      flying.push_back(&u);
    }
  } catch (const InputError& e) {
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, e.what());
  }
  plan.search_time_s = seconds_since(stage);

  // 3. Timing at cruise.
  stage = Clock::now();
  for (std::size_t i = 0; i < plan.uavs.size(); ++i) {
    UavPlan& up = plan.uavs[i];
    up.timing = time_parametrize(up.waypoints_m, flying[i]->vehicle, options.timing);
    if (up.timing.status == TimeParametrizationStatus::kInvalidInput || !up.timing.reference)
      return fail(std::move(plan), GlobalPlanStatus::kInvalidInput,
                  up.name + ": " + up.timing.message);
    if (!up.timing.violations.empty())
      return fail(std::move(plan), GlobalPlanStatus::kValidationFailed,
                  fmt::format("{}: {}", up.name, up.timing.violations.front().description));
  }
  plan.timing_time_s = seconds_since(stage);

  // 4. Dense validation of terrain clearance and the altitude band (not separation).
  stage = Clock::now();
  std::vector<TimedPath> timed;
  for (const UavPlan& up : plan.uavs) {
    TimedPath p;
    p.name = up.name;
    for (std::size_t k = 0; k < up.timing.samples.size(); ++k) {
      p.waypoints_m.push_back(up.timing.samples[k].position_m);
      p.times_s.push_back(up.timing.sample_times_s[k]);
    }
    timed.push_back(std::move(p));
  }
  PlanValidationOptions vo;
  vo.enforce_separation = false;  // left to the flight: these paths are not deconflicted
  vo.terrain_step_m = options.validation_step_m;
  vo.separation_period_s = 1.0;
  PlanValidationReport report;
  try {
    report = validate_plan(*problem.terrain, timed, problem.limits, vo);
  } catch (const InputError& e) {
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, e.what());
  }
  plan.validation_time_s = seconds_since(stage);
  plan.validation.min_terrain_clearance_m = report.min_clearance_m;
  plan.validation.min_altitude_m = report.min_altitude_m;
  plan.validation.max_altitude_m = report.max_altitude_m;
  plan.validation.min_separation_m = report.min_separation_m;
  plan.validation.samples_checked = static_cast<int>(report.terrain_samples);
  plan.total_time_s = seconds_since(start);
  if (!report.passed())
    return fail(std::move(plan), GlobalPlanStatus::kValidationFailed, report.summary(1));
  plan.status = GlobalPlanStatus::kPlanned;
  return plan;
}

}  // namespace ridgeline::baselines
