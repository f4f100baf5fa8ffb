#include "planning/team_scenarios.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>


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

}  // namespace ridgeline::planning
