// Scenarios shared by the trajectory optimizer's tests and benchmark: a default-like terrain
// (DESIGN §7: 2 km × 2 km, 7 peaks 80–300 m high) and initial guesses that are straight lines
// lifted above the terrain (the optimizer's own tests do not depend on the path search).
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "planning/trajectory_optimizer.hpp"
#include "world/terrain.hpp"

namespace ridgeline::planning::testing {

inline world::PeakTerrain default_like_terrain(
    world::PeakCombination combination = world::PeakCombination::kMax) {
  world::PeakTerrainConfig c;
  c.combination = combination;
  //             x_m     y_m    h_m    a_m    b_m
  c.peaks = {{600.0, 500.0, 220.0, 180.0, 140.0},  {1100.0, 900.0, 300.0, 200.0, 220.0},
             {1500.0, 500.0, 150.0, 150.0, 120.0}, {500.0, 1300.0, 260.0, 160.0, 200.0},
             {1000.0, 1600.0, 120.0, 140.0, 140.0}, {1600.0, 1200.0, 80.0, 120.0, 100.0},
             {1400.0, 1750.0, 180.0, 130.0, 150.0}};
  return world::PeakTerrain(c);
}

/// A polyline from a to b with points every ≤ spacing_m (horizontally), lifted to at least
/// H + lift_m and H_min, and smoothed so the grade stays ≤ max_grade where the ends allow it
/// (a rough stand-in for the path search's profile). The ends stay exactly a and b.
inline std::vector<Vec3> lifted_line(const world::Terrain& terrain, const Vec3& a, const Vec3& b,
                                     double spacing_m = 20.0, double lift_m = 35.0,
                                     double min_altitude_m = 40.0, double max_grade = 0.25) {
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

/// `count` UAVs starting side by side in the south-west (30 m apart on a diagonal, like the
/// default scenario) with one target each spread over the north-east, 40 m above the terrain.
inline TrajectoryProblem team_problem(const world::Terrain& terrain, int count) {
  TrajectoryProblem problem;
  problem.terrain = &terrain;
  const int columns = std::max(1, static_cast<int>(std::ceil(std::sqrt(count))));
  for (int i = 0; i < count; ++i) {
    TrajectoryUav u;
    u.name = fmt::format("uav{}", i + 1);
    const Vec3 start(100.0 + 30.0 * (i % 10) + 10.0 * (i / 10), 130.0 - 30.0 * (i % 10) + 60.0 * (i / 10) + 200.0,
                     0.0);
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

}  // namespace ridgeline::planning::testing
