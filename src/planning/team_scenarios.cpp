#include "planning/team_scenarios.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace ridgeline::planning {

world::PeakTerrain default_like_terrain(world::PeakCombination combination) {
  world::PeakTerrainConfig c;
  c.combination = combination;
  //             x_m     y_m    h_m    a_m    b_m
  c.peaks = {{600.0, 500.0, 220.0, 180.0, 140.0},  {1100.0, 900.0, 300.0, 200.0, 220.0},
             {1500.0, 500.0, 150.0, 150.0, 120.0}, {500.0, 1300.0, 260.0, 160.0, 200.0},
             {1000.0, 1600.0, 120.0, 140.0, 140.0}, {1600.0, 1200.0, 80.0, 120.0, 100.0},
             {1400.0, 1750.0, 180.0, 130.0, 150.0}};
  return world::PeakTerrain(c);
}

std::vector<Vec3> lifted_line(const world::Terrain& terrain, const Vec3& a, const Vec3& b,
                              double spacing_m, double lift_m, double min_altitude_m,
                              double max_grade) {
  const double length = (b - a).head<2>().norm();
  const int n = std::max(2, static_cast<int>(std::ceil(length / spacing_m)));
  std::vector<Vec3> p(n + 1);
  for (int k = 0; k <= n; ++k) {
    const double s = static_cast<double>(k) / n;
    p[k] = a + s * (b - a);
    if (k > 0 && k < n)
      p[k].z() = std::max({p[k].z(), terrain.height(p[k].x(), p[k].y()) + lift_m, min_altitude_m});
  }
  const double step = length / n;
  for (int k = 1; k < n; ++k) p[k].z() = std::max(p[k].z(), p[k - 1].z() - max_grade * step);
  for (int k = n - 1; k > 0; --k) p[k].z() = std::max(p[k].z(), p[k + 1].z() - max_grade * step);
  return p;
}

TrajectoryProblem straight_line_team(const world::Terrain& terrain, int count) {
  TrajectoryProblem problem;
  problem.terrain = &terrain;
  const int columns = std::max(1, static_cast<int>(std::ceil(std::sqrt(count))));
  for (int i = 0; i < count; ++i) {
    TrajectoryUav u;
    u.name = fmt::format("uav{}", i + 1);
    const Vec3 start(100.0 + 30.0 * (i % 10) + 10.0 * (i / 10),
                     130.0 - 30.0 * (i % 10) + 60.0 * (i / 10) + 200.0, 0.0);
    const int row = i / columns;
    const int col = i % columns;
    const double span = 600.0;
    Vec3 target(1250.0 + span * (col + 0.5) / columns, 1150.0 + span * (row + 0.5) / columns, 0.0);
    Vec3 s = start;
    s.z() = std::max(60.0, terrain.height(s.x(), s.y()) + 30.0);
    target.z() = std::max(60.0, terrain.height(target.x(), target.y()) + 40.0);
    u.initial_path_m = lifted_line(terrain, s, target);
    problem.uavs.push_back(u);
  }
  return problem;
}

GlobalPlanningProblem scaled_team(const GlobalPlanningProblem& base, int uav_count) {
  if (uav_count < 1) throw InputError("uav_count", fmt::format("must be >= 1, got {}", uav_count));
  if (!base.terrain || base.uavs.empty() || base.targets.empty())
    throw InputError("base", "needs terrain, at least one UAV and one target");
  const world::Terrain& terrain = *base.terrain;
  GlobalPlanningProblem p = base;
  const auto count = static_cast<std::size_t>(uav_count);
  if (p.uavs.size() > count) p.uavs.resize(count);
  if (p.targets.size() > count) p.targets.resize(count);

  // Starts: a launch field around the base starts' centroid, on a lattice aligned with the
  // first UAV's heading, filled ring by ring outward (points outside the area, 20 m inset, or
  // closer than the spacing to a start already placed are skipped).
  Vec2 centroid = Vec2::Zero();
  for (const PlannerUav& u : base.uavs) centroid += u.start_m.head<2>();
  centroid /= static_cast<double>(base.uavs.size());
  const PlannerUav& lead = base.uavs.front();
  const Vec2 ahead(std::cos(lead.start_heading_rad), std::sin(lead.start_heading_rad));
  const Vec2 across(ahead.y(), -ahead.x());
  const double spacing_m = std::max(30.0, 2.0 * base.limits.separation_m);
  const double start_floor_m = base.limits.clearance_floor_m(terrain) + 10.0;
  const Vec2 inner_min = base.area.min_m + Vec2(20.0, 20.0);
  const Vec2 inner_max = base.area.max_m - Vec2(20.0, 20.0);
  constexpr int kMaxRing = 100;
  for (int ring = 1; p.uavs.size() < count && ring <= kMaxRing; ++ring)
    for (int a = -ring; a <= ring && p.uavs.size() < count; ++a)
      for (int c = -ring; c <= ring && p.uavs.size() < count; ++c) {
        if (std::max(std::abs(a), std::abs(c)) != ring) continue;
        const Vec2 xy = centroid + spacing_m * (a * ahead + c * across);
        if ((xy.array() < inner_min.array()).any() || (xy.array() > inner_max.array()).any()) continue;
        bool clear = true;
        for (const PlannerUav& other : p.uavs)
          clear = clear && (other.start_m.head<2>() - xy).norm() >= 0.99 * spacing_m;
        if (!clear) continue;
        PlannerUav u = lead;
        u.name = fmt::format("uav{}", p.uavs.size() + 1);
        const double z = std::max(lead.start_m.z(), terrain.height(xy.x(), xy.y()) + start_floor_m);
        u.start_m = Vec3(xy.x(), xy.y(), std::max(z, base.limits.altitude.min_m));
        p.uavs.push_back(std::move(u));
      }
  if (p.uavs.size() < count)
    throw InputError("uav_count", fmt::format("{} UAVs do not fit in the area around the base starts "
                                              "({} placed)",
                                              uav_count, p.uavs.size()));

  // Targets: a lattice over the (grown) bounding box of the base targets.
  Vec2 lo = base.targets.front().position_m.head<2>();
  Vec2 hi = lo;
  for (const AllocationTarget& t : base.targets) {
    lo = lo.cwiseMin(t.position_m.head<2>());
    hi = hi.cwiseMax(t.position_m.head<2>());
  }
  const Vec2 middle = 0.5 * (lo + hi);
  const Vec2 half = (0.5 * (hi - lo)).cwiseMax(Vec2(350.0, 350.0));
  lo = (middle - half).cwiseMax(base.area.min_m + Vec2(30.0, 30.0));
  hi = (middle + half).cwiseMin(base.area.max_m - Vec2(30.0, 30.0));
  const double target_floor_m = base.limits.clearance_floor_m(terrain) + 40.0;
  for (int side = 2; p.targets.size() < count; ++side) {
    if (side > 64) throw InputError("uav_count", fmt::format("{} targets do not fit", uav_count));
    std::vector<AllocationTarget> added;
    for (int row = 0; row < side && p.targets.size() + added.size() < count; ++row)
      for (int col = 0; col < side && p.targets.size() + added.size() < count; ++col) {
        const Vec2 xy = lo + Vec2((hi.x() - lo.x()) * (col + 0.5) / side,
                                  (hi.y() - lo.y()) * (row + 0.5) / side);
        const double z = terrain.height(xy.x(), xy.y()) + target_floor_m;
        if (z < base.limits.altitude.min_m || z > base.limits.altitude.max_m) continue;
        const Vec3 position(xy.x(), xy.y(), z);
        bool clear = true;
        for (const auto* list : {&p.targets, &added})
          for (const AllocationTarget& t : *list)
            clear = clear && (t.position_m - position).norm() >= 40.0;
        if (clear) added.push_back({fmt::format("site{}", p.targets.size() + added.size() + 1), position, 1});
      }
    if (p.targets.size() + added.size() >= count) p.targets.insert(p.targets.end(), added.begin(), added.end());
  }
  return p;
}

}  // namespace ridgeline::planning
