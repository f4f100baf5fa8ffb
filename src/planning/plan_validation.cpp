#include "planning/plan_validation.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace ridgeline::planning {
namespace {

void check_options(const PlanValidationOptions& o) {
  auto finite = [](double v) { return std::isfinite(v); };
  if (!(o.terrain_step_m > 0.0 && o.terrain_step_m <= 5.0))
    throw InputError("options.terrain_step_m", "must be in (0, 5] m");
  if (!(o.separation_period_s > 0.0 && finite(o.separation_period_s)))
    throw InputError("options.separation_period_s", "must be positive");
  if (!(o.window_s > 0.0 && finite(o.window_s)))
    throw InputError("options.window_s", "must be positive");
  if (!(o.tolerance_m >= 0.0 && finite(o.tolerance_m)))
    throw InputError("options.tolerance_m", "must be finite and >= 0");
}

void check_path(const TimedPath& p, int i) {
  const std::string root = fmt::format("paths[{}]", i);
  if (p.waypoints_m.empty()) throw InputError(root + ".waypoints_m", "is empty");
  if (p.times_s.size() != p.waypoints_m.size())
    throw InputError(root + ".times_s", fmt::format("has {} entries for {} waypoints",
                                                    p.times_s.size(), p.waypoints_m.size()));
  for (std::size_t k = 0; k < p.waypoints_m.size(); ++k) {
    if (!p.waypoints_m[k].allFinite())
      throw InputError(fmt::format("{}.waypoints_m[{}]", root, k), "is not finite");
    if (!std::isfinite(p.times_s[k]))
      throw InputError(fmt::format("{}.times_s[{}]", root, k), "is not finite");
    if (k > 0 && !(p.times_s[k] > p.times_s[k - 1]))
      throw InputError(fmt::format("{}.times_s[{}]", root, k), "times must strictly increase");
  }
}

std::string uav_name(const std::vector<TimedPath>& paths, int i) {
  return paths[i].name.empty() ? fmt::format("#{}", i) : paths[i].name;
}

// Position of a path at time t with a cursor that only moves forward (t is non-decreasing
// within one sweep). Returns the segment index in `segment`.
struct PathCursor {
  const TimedPath* path = nullptr;
  std::size_t k = 0;

  Vec3 at(double t, int& segment) {
    const auto& ts = path->times_s;
    const auto& ps = path->waypoints_m;
    if (ps.size() == 1 || t <= ts.front()) {
      segment = 0;
      return ps.front();
    }
    if (t >= ts.back()) {
      segment = static_cast<int>(ps.size()) - 2;
      return ps.back();
    }
    while (k + 1 < ts.size() && ts[k + 1] < t) ++k;
    segment = static_cast<int>(k);
    const double s = (t - ts[k]) / (ts[k + 1] - ts[k]);
    return ps[k] + s * (ps[k + 1] - ps[k]);
  }
};

}  // namespace

std::string_view to_string(ViolationKind kind) {
  switch (kind) {
    case ViolationKind::kTerrainClearance: return "terrain clearance (eq. 19-20)";
    case ViolationKind::kAltitudeLow: return "altitude below H_min (eq. 14)";
    case ViolationKind::kAltitudeHigh: return "altitude above H_max (eq. 14)";
    case ViolationKind::kSeparation: return "separation (eq. 21)";
  }
  return "unknown";
}

std::string PlanValidationReport::summary(int max_lines) const {
  if (violations.empty()) {
    return fmt::format("passed: min clearance {:.2f} m, min separation {:.2f} m, altitude "
                       "[{:.1f}, {:.1f}] m",
                       min_clearance_m, min_separation_m, min_altitude_m, max_altitude_m);
  }
  std::string out = fmt::format("{} violation(s)", violations.size());
  for (int i = 0; i < static_cast<int>(violations.size()) && i < max_lines; ++i)
    out += "\n" + violations[i].description;
  return out;
}

PlanValidationReport validate_plan(const world::Terrain& terrain,
                                   const std::vector<TimedPath>& paths,
                                   const world::SafetyLimits& limits,
                                   const PlanValidationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  world::validate(limits);
  check_options(options);
  for (int i = 0; i < static_cast<int>(paths.size()); ++i) check_path(paths[i], i);

  PlanValidationReport report;
  const double required_m = limits.clearance_floor_m(terrain);
  const int n_uav = static_cast<int>(paths.size());

  // Terrain clearance and altitude band, per UAV and segment.
  for (int i = 0; i < n_uav; ++i) {
    const auto& ps = paths[i].waypoints_m;
    const auto& ts = paths[i].times_s;
    for (std::size_t k = 0; k < ps.size(); ++k) {
      const double z = ps[k].z();
      report.min_altitude_m = std::min(report.min_altitude_m, z);
      report.max_altitude_m = std::max(report.max_altitude_m, z);
      const double low = limits.altitude.min_m - z;
      const double high = z - limits.altitude.max_m;
      if (low > options.tolerance_m || high > options.tolerance_m) {
        PlanViolation v;
        v.kind = low > 0.0 ? ViolationKind::kAltitudeLow : ViolationKind::kAltitudeHigh;
        v.uav = i;
        v.segment = static_cast<int>(k);
        v.time_s = ts[k];
        v.position_m = ps[k];
        v.amount_m = std::max(low, high);
        v.description = fmt::format(
            "{}: UAV {} waypoint {} at t = {:.2f} s, ({:.1f}, {:.1f}, {:.1f}): z = {:.2f} m is "
            "{:.2f} m outside [{:.1f}, {:.1f}] m",
            to_string(v.kind), uav_name(paths, i), k, v.time_s, ps[k].x(), ps[k].y(), ps[k].z(), z,
            v.amount_m, limits.altitude.min_m, limits.altitude.max_m);
        report.violations.push_back(std::move(v));
      }
    }
    const std::size_t segments = ps.size() == 1 ? 1 : ps.size() - 1;
    for (std::size_t k = 0; k < segments; ++k) {
      const Vec3 a = ps[k];
      const Vec3 b = ps.size() == 1 ? a : ps[k + 1];
      const double horizontal = (b - a).head<2>().norm();
      const int pieces = std::max(1, static_cast<int>(std::ceil(horizontal / options.terrain_step_m)));
      double worst = std::numeric_limits<double>::infinity();
      double worst_s = 0.0;
      for (int q = 0; q <= pieces; ++q) {
        const double s = static_cast<double>(q) / pieces;
        const Vec3 p = a + s * (b - a);
        double clearance = p.z() - terrain.height(p.x(), p.y());
        // A NaN height (a broken terrain query) is the worst clearance, never a pass.
        if (std::isnan(clearance)) clearance = -std::numeric_limits<double>::infinity();
        ++report.terrain_samples;
        if (clearance < worst) {
          worst = clearance;
          worst_s = s;
        }
      }
      const Vec3 p = a + worst_s * (b - a);
      if (worst < report.min_clearance_m) {
        report.min_clearance_m = worst;
        report.min_clearance_uav = i;
        report.min_clearance_position_m = p;
      }
      if (required_m - worst > options.tolerance_m) {
        PlanViolation v;
        v.kind = ViolationKind::kTerrainClearance;
        v.uav = i;
        v.segment = static_cast<int>(k);
        v.time_s = ps.size() == 1 ? ts[0] : ts[k] + worst_s * (ts[k + 1] - ts[k]);
        v.position_m = p;
        v.amount_m = required_m - worst;
        v.description = fmt::format(
            "{}: UAV {} segment {} at t = {:.2f} s, ({:.1f}, {:.1f}, {:.1f}): {:.2f} m above the "
            "terrain, {:.2f} m below the required {:.2f} m",
            to_string(v.kind), uav_name(paths, i), k, v.time_s, p.x(), p.y(), p.z(), worst,
            v.amount_m, required_m);
        report.violations.push_back(std::move(v));
      }
    }
  }

  // Separation at equal times, windowed with bounding-box pruning.
  if (n_uav >= 2) {
    double t_lo = std::numeric_limits<double>::infinity();
    double t_hi = -std::numeric_limits<double>::infinity();
    for (const TimedPath& p : paths) {
      t_lo = std::min(t_lo, p.times_s.front());
      t_hi = std::max(t_hi, p.times_s.back());
    }
    const double dt = options.separation_period_s;
    const long samples = static_cast<long>(std::ceil((t_hi - t_lo) / dt - 1e-9)) + 1;
    const long per_window = std::max(1L, static_cast<long>(std::round(options.window_s / dt)));
    const double d_safe = options.enforce_separation ? limits.separation_m : 0.0;

    std::vector<PathCursor> cursors(n_uav);
    for (int i = 0; i < n_uav; ++i) cursors[i].path = &paths[i];
    std::vector<Vec3> pos(static_cast<std::size_t>(n_uav * per_window));
    std::vector<int> seg(pos.size());
    std::vector<Eigen::AlignedBox3d> box(n_uav);
    // An open run of violating samples per pair: its worst sample so far (index −1: none).
    struct Run {
      long worst_sample = -1;
      double worst_distance = 0.0;
      Vec3 position = Vec3::Zero();
      int segment = 0;
    };
    std::vector<Run> runs(static_cast<std::size_t>(n_uav * n_uav));
    auto close_run = [&](int i, int j) {
      Run& r = runs[i * n_uav + j];
      if (r.worst_sample < 0) return;
      PlanViolation v;
      v.kind = ViolationKind::kSeparation;
      v.uav = i;
      v.other_uav = j;
      v.segment = r.segment;
      v.time_s = std::min(t_lo + r.worst_sample * dt, t_hi);
      v.position_m = r.position;
      v.amount_m = d_safe - r.worst_distance;
      v.description = fmt::format(
          "{}: UAVs {} and {} at t = {:.2f} s near ({:.1f}, {:.1f}, {:.1f}) are {:.2f} m apart, "
          "{:.2f} m closer than {:.2f} m",
          to_string(v.kind), uav_name(paths, i), uav_name(paths, j), v.time_s, r.position.x(),
          r.position.y(), r.position.z(), r.worst_distance, v.amount_m, d_safe);
      report.violations.push_back(std::move(v));
      r = Run{};
    };

    for (long w0 = 0; w0 < samples; w0 += per_window) {
      const long count = std::min(per_window, samples - w0);
      for (int i = 0; i < n_uav; ++i) {
        box[i].setEmpty();
        for (long m = 0; m < count; ++m) {
          const double t = std::min(t_lo + (w0 + m) * dt, t_hi);
          const std::size_t idx = static_cast<std::size_t>(i * per_window + m);
          pos[idx] = cursors[i].at(t, seg[idx]);
          box[i].extend(pos[idx]);
        }
      }
      for (int i = 0; i < n_uav; ++i) {
        for (int j = i + 1; j < n_uav; ++j) {
          if (box[i].exteriorDistance(box[j]) > d_safe &&
              box[i].exteriorDistance(box[j]) > report.min_separation_m) {
            close_run(i, j);
            continue;
          }
          for (long m = 0; m < count; ++m) {
            const std::size_t a = static_cast<std::size_t>(i * per_window + m);
            const std::size_t b = static_cast<std::size_t>(j * per_window + m);
            const double d = (pos[a] - pos[b]).norm();
            ++report.separation_samples;
            if (d < report.min_separation_m) {
              report.min_separation_m = d;
              report.min_separation_uavs[0] = i;
              report.min_separation_uavs[1] = j;
              report.min_separation_time_s = std::min(t_lo + (w0 + m) * dt, t_hi);
            }
            Run& r = runs[i * n_uav + j];
            if (d_safe - d > options.tolerance_m) {
              if (r.worst_sample < 0 || d < r.worst_distance) {
                r.worst_sample = w0 + m;
                r.worst_distance = d;
                r.position = pos[a];
                r.segment = seg[a];
              }
            } else {
              close_run(i, j);
            }
          }
        }
      }
    }
    for (int i = 0; i < n_uav; ++i)
      for (int j = i + 1; j < n_uav; ++j) close_run(i, j);
  }

  report.compute_time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace ridgeline::planning
