#include "mission/team_scenario.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/random.hpp"

namespace ridgeline::mission {
namespace {

constexpr double kTakeoffInsetM = 50.0;
constexpr double kTargetInsetM = 100.0;
constexpr double kKeepAwayFromTakeoffM = 300.0;

struct Box {
  Vec2 min = Vec2::Zero();
  Vec2 max = Vec2::Zero();
  double distance(const Vec2& p) const {
    return (p.cwiseMax(min).cwiseMin(max) - p).norm();
  }
};

// The take-off lattice: N starts, row by row from the south-west corner.
std::vector<UavSpec> takeoff_grid(const Scenario& base, const world::Terrain& terrain, int count,
                                  Box& field) {
  const world::SafetyLimits& limits = base.safety;
  const double spacing = takeoff_spacing_m(limits);
  const double width = base.area.x_max_m - base.area.x_min_m - 2.0 * kTakeoffInsetM;
  const double height = base.area.y_max_m - base.area.y_min_m - 2.0 * kTakeoffInsetM;
  const int max_columns = width >= 0.0 ? static_cast<int>(std::floor(width / spacing)) + 1 : 0;
  const int max_rows = height >= 0.0 ? static_cast<int>(std::floor(height / spacing)) + 1 : 0;
  const long capacity = static_cast<long>(max_columns) * max_rows;
  if (count > capacity)
    throw InputError("uavs", fmt::format("{} UAVs do not fit on a take-off grid of {:.0f} m spacing "
                                         "in the area ({:.0f} m x {:.0f} m, {:.0f} m inset): at "
                                         "most {}",
                                         count, spacing, width + 2.0 * kTakeoffInsetM,
                                         height + 2.0 * kTakeoffInsetM, kTakeoffInsetM, capacity));
  int columns = std::min(max_columns, static_cast<int>(std::ceil(std::sqrt(count))));
  const int rows = (count + columns - 1) / columns;
  const Vec2 corner(base.area.x_min_m + kTakeoffInsetM, base.area.y_min_m + kTakeoffInsetM);
  field = {corner, corner + spacing * Vec2(columns - 1, rows - 1)};
  const Vec2 centre(0.5 * (base.area.x_min_m + base.area.x_max_m),
                    0.5 * (base.area.y_min_m + base.area.y_max_m));
  const UavSpec lead = base.uavs.empty() ? UavSpec{} : base.uavs.front();
  const double floor_m = limits.clearance_floor_m(terrain);
  std::vector<UavSpec> uavs;
  for (int i = 0; i < count; ++i) {
    const Vec2 xy = corner + spacing * Vec2(i % columns, i / columns);
    UavSpec u = lead;
    u.name = fmt::format("uav{}", i + 1);
    u.assigned_targets.clear();
    u.end_position_m.reset();
    const double z = std::max(terrain.height(xy.x(), xy.y()) + floor_m + 20.0,
                              limits.altitude.min_m + 20.0);
    if (z > limits.altitude.max_m - 10.0)
      throw InputError("uavs", fmt::format("the take-off field at ({:.0f}, {:.0f}) is too high: a "
                                           "start there would fly at {:.0f} m, above the band's "
                                           "{:.0f} m",
                                           xy.x(), xy.y(), z, limits.altitude.max_m));
    u.start_position_m = Vec3(xy.x(), xy.y(), z);
    u.start_heading_rad = std::atan2(centre.y() - xy.y(), centre.x() - xy.x());
    uavs.push_back(std::move(u));
  }
  return uavs;
}

std::vector<InspectionTarget> spread_targets(const Scenario& base, const world::Terrain& terrain,
                                             int count, const Box& field, Rng& rng) {
  const world::SafetyLimits& limits = base.safety;
  const double floor_m = limits.clearance_floor_m(terrain);
  const double radius_m = base.targets.empty() ? 30.0 : base.targets.front().inspection_radius_m;
  const double x0 = base.area.x_min_m + kTargetInsetM, x1 = base.area.x_max_m - kTargetInsetM;
  const double y0 = base.area.y_min_m + kTargetInsetM, y1 = base.area.y_max_m - kTargetInsetM;
  if (!(x1 > x0 && y1 > y0))
    throw InputError("targets", "the area is too small to hold targets 100 m inside its edges");
  std::vector<InspectionTarget> targets;
  // Spacing 60 m first; a crowded area halves it down to 2·d_safe.
  for (double spacing = 60.0; targets.size() < static_cast<std::size_t>(count);
       spacing *= 0.5) {
    if (spacing < 2.0 * limits.separation_m)
      throw InputError("targets", fmt::format("{} targets do not fit in the area ({} placed at "
                                              "{:.0f} m apart)",
                                              count, targets.size(), 4.0 * limits.separation_m));
    for (int attempt = 0; attempt < 200 * count && targets.size() < static_cast<std::size_t>(count);
         ++attempt) {
      const Vec2 xy(rng.uniform(x0, x1), rng.uniform(y0, y1));
      const double above = rng.uniform(20.0, 60.0);
      const int priority = rng.uniform() < 0.2 ? 2 : 1;
      if (field.distance(xy) < kKeepAwayFromTakeoffM) continue;
      const double z = std::max(terrain.height(xy.x(), xy.y()) + floor_m + above,
                                limits.altitude.min_m + above);
      if (z > limits.altitude.max_m - 10.0) continue;
      const Vec3 p(xy.x(), xy.y(), z);
      const bool clear = std::all_of(targets.begin(), targets.end(), [&](const InspectionTarget& t) {
        return (t.position_m - p).norm() >= spacing;
      });
      if (clear)
        targets.push_back({fmt::format("site{}", targets.size() + 1), p, priority, radius_m});
    }
  }
  return targets;
}

std::vector<world::Threat> scatter_threats(const Scenario& base, const world::Terrain& terrain,
                                           int count, const Box& field, Rng& rng) {
  const world::SafetyLimits& limits = base.safety;
  const double floor_m = limits.clearance_floor_m(terrain);
  std::vector<world::Threat> threats;
  const double x0 = base.area.x_min_m, x1 = base.area.x_max_m;
  const double y0 = base.area.y_min_m, y1 = base.area.y_max_m;
  for (int attempt = 0; attempt < 1000 * std::max(count, 1) && static_cast<int>(threats.size()) < count;
       ++attempt) {
    world::Threat t;
    t.name = fmt::format("t{}", threats.size() + 1);
    t.radius_m = rng.uniform(35.0, 50.0);
    const double inset = t.radius_m + 150.0;
    const Vec2 xy(rng.uniform(x0 + inset, x1 - inset), rng.uniform(y0 + inset, y1 - inset));
    const double above = rng.uniform(60.0, 130.0);
    const double heading = rng.uniform(-kPi, kPi);
    const double speed = rng.uniform(3.5, 6.5);
    t.appear_s = rng.uniform(20.0, 120.0);
    t.vanish_s = t.appear_s + rng.uniform(150.0, 230.0);
    if (!(x1 - inset > x0 + inset && y1 - inset > y0 + inset)) break;
    if (field.distance(xy) < kKeepAwayFromTakeoffM + t.radius_m) continue;
    const double z = std::min(std::max(terrain.height(xy.x(), xy.y()) + floor_m + above,
                                       limits.altitude.min_m + above),
                              limits.altitude.max_m - t.radius_m);
    t.centre_m = Vec3(xy.x(), xy.y(), z);
    t.velocity_m_s = Vec3(speed * std::cos(heading), speed * std::sin(heading), 0.0);
    threats.push_back(std::move(t));
  }
  if (static_cast<int>(threats.size()) < count)
    throw InputError("threats", fmt::format("{} threats do not fit in the area ({} placed)", count,
                                            threats.size()));
  return threats;
}

double area_km2(const Area& a) {
  return (a.x_max_m - a.x_min_m) * (a.y_max_m - a.y_min_m) * 1e-6;
}

}  // namespace

double takeoff_spacing_m(const world::SafetyLimits& limits) {
  return std::max(30.0, limits.separation_m + 5.0);
}

Scenario make_team_scenario(const Scenario& base, const world::Terrain& terrain,
                            const TeamScenarioOptions& options) {
  if (options.uavs < 1) throw InputError("uavs", fmt::format("must be >= 1, got {}", options.uavs));
  if (options.targets < 1)
    throw InputError("targets", fmt::format("must be >= 1, got {}", options.targets));
  if (options.threats < -1)
    throw InputError("threats", fmt::format("must be >= 0, got {}", options.threats));
  Scenario s = base;
  s.name = fmt::format("team{}", options.uavs);
  s.seed = options.seed;
  Rng rng(derive_seed(options.seed, 20));
  Box field;
  s.uavs = takeoff_grid(base, terrain, options.uavs, field);
  s.targets = spread_targets(base, terrain, options.targets, field, rng);
  const int threats =
      options.threats >= 0
          ? options.threats
          : static_cast<int>(std::lround(options.threats_per_km2 * area_km2(base.area)));
  s.threats = scatter_threats(base, terrain, threats, field, rng);
  return s;
}

}  // namespace ridgeline::mission
