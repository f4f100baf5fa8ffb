#include "planning/path_search.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"

namespace ridgeline::planning {
namespace {

using world::Peak;
using world::PeakTerrain;
using world::PeakTerrainConfig;

// The dense check of the test samples 4× finer than the planner's own (1 m) check, so it is an
// independent look at the same polyline.
constexpr double kTestCheckStep_m = 0.25;
// Clearance tolerance: profile arithmetic round-off only (the planner pads 0.5 m for curvature).
constexpr double kClearanceTolerance_m = 1e-6;

void expect_path_safe(const PeakTerrain& terrain, const PathSearchOptions& o, const PathResult& r) {
  const PathCheck check = check_path(terrain, r.waypoints_m, kTestCheckStep_m);
  const world::SafetyLimits limits;  // the grids of these tests use the default limits
  EXPECT_GE(check.min_clearance_m, limits.clearance_floor_m(terrain) - kClearanceTolerance_m);
  EXPECT_LE(check.max_pitch_rad, o.max_pitch_rad + 1e-9);
  EXPECT_GE(check.min_altitude_m, limits.altitude.min_m - 1e-6);
  EXPECT_LE(check.max_altitude_m, limits.altitude.max_m + 1e-6);
  EXPECT_GE(r.min_clearance_m, limits.clearance_floor_m(terrain) - kClearanceTolerance_m);
}

TEST(PathSearch, FlatTerrainGivesTheStraightLine) {
  const PeakTerrain flat(PeakTerrainConfig{});
  const PathSearchOptions o;
  const ClearanceGrid grid(flat, SearchArea{}, world::SafetyLimits{});
  const NamedPoint start{"uav0", Vec3(100, 150, 100)};
  const NamedPoint target{"t0", Vec3(1700, 1300, 100)};
  const PathResult r = plan_initial_path(grid, start, {target});
  ASSERT_EQ(r.status, PathStatus::kFound) << r.message;
  const double straight = (target.position_m - start.position_m).norm();
  // Any kink would add metres; 1e-6 relative is round-off of summing segment lengths.
  EXPECT_NEAR(r.length_m, straight, 1e-6 * straight);
  EXPECT_EQ(r.waypoints_m.front(), start.position_m);
  EXPECT_EQ(r.waypoints_m.back(), target.position_m);
  expect_path_safe(flat, o, r);
}

PeakTerrainConfig wall_terrain() {
  // A wall along x = 1000 from y = 0 to y = 1500: 600 m peaks (above H_max = 500 m) every 50 m
  // with σ = 80 m, so even between two peaks the terrain stays above 540 m.
  PeakTerrainConfig cfg;
  for (int k = 0; k <= 30; ++k) cfg.peaks.push_back(Peak{1000.0, 50.0 * k, 600.0, 80.0, 80.0});
  return cfg;
}

TEST(PathSearch, WallOfPeaksForcesADetour) {
  const PeakTerrain terrain(wall_terrain());
  const PathSearchOptions o;
  const ClearanceGrid grid(terrain, SearchArea{}, world::SafetyLimits{}, o);
  const NamedPoint start{"uav0", Vec3(200, 200, 100)};
  const NamedPoint target{"t0", Vec3(1800, 200, 100)};
  const PathResult r = plan_initial_path(grid, start, {target});
  ASSERT_EQ(r.status, PathStatus::kFound) << r.message;
  double max_y = 0.0;
  for (const auto& p : r.waypoints_m) max_y = std::max(max_y, p.y());
  // The only way round is north of the wall's end (y = 1500 plus the flank of its last peak).
  EXPECT_GT(max_y, 1500.0);
  EXPECT_GT(r.length_m, 2.0 * 1300.0);  // at least up to y ≈ 1500 and back down, twice
  expect_path_safe(terrain, o, r);
}

PeakTerrainConfig ring_terrain(const Vec2& centre) {
  // 60 peaks of 700 m on a circle of radius 300 m: 31 m apart with σ = 60 m, a closed wall far
  // above H_max = 500 m.
  PeakTerrainConfig cfg;
  for (int k = 0; k < 60; ++k) {
    const double a = 2.0 * kPi * k / 60.0;
    cfg.peaks.push_back(Peak{centre.x() + 300.0 * std::cos(a), centre.y() + 300.0 * std::sin(a),
                             700.0, 60.0, 60.0});
  }
  return cfg;
}

TEST(PathSearch, TargetInsideRingIsUnreachableAndNamed) {
  const PeakTerrain terrain(ring_terrain(Vec2(1000, 1000)));
  const ClearanceGrid grid(terrain, SearchArea{}, world::SafetyLimits{});
  const NamedPoint start{"uav0", Vec3(150, 150, 100)};
  const NamedPoint inside{"inspect-ring", Vec3(1000, 1000, 100)};
  PathResult r = plan_initial_path(grid, start, {inside});
  EXPECT_EQ(r.status, PathStatus::kUnreachable);
  EXPECT_EQ(r.failed_point, "inspect-ring");
  EXPECT_NE(r.message.find("'inspect-ring'"), std::string::npos) << r.message;

  // The same ring around the start: the start is named.
  r = plan_initial_path(grid, NamedPoint{"uav-boxed", Vec3(1000, 1000, 100)},
                        {NamedPoint{"t", Vec3(150, 150, 100)}});
  EXPECT_EQ(r.status, PathStatus::kUnreachable);
  EXPECT_EQ(r.failed_point, "uav-boxed");
  EXPECT_NE(r.message.find("'uav-boxed'"), std::string::npos) << r.message;
}

TEST(PathSearch, StartOrTargetInsideTheTerrainIsAnErrorNamingIt) {
  PeakTerrainConfig cfg;
  cfg.peaks.push_back(Peak{1000, 1000, 300, 150, 150});
  const PeakTerrain terrain(cfg);
  const ClearanceGrid grid(terrain, SearchArea{}, world::SafetyLimits{});
  const NamedPoint ok_start{"uav0", Vec3(100, 100, 100)};
  const NamedPoint buried_target{"t-buried", Vec3(1000, 1000, 250)};  // ground is at 300 m
  PathResult r =
      plan_initial_path(grid, ok_start, {NamedPoint{"t-ok", Vec3(1800, 1800, 100)}, buried_target});
  EXPECT_EQ(r.status, PathStatus::kInvalidInput);
  EXPECT_EQ(r.failed_point, "t-buried");
  EXPECT_NE(r.message.find("inside the terrain"), std::string::npos) << r.message;

  const NamedPoint buried_start{"uav-buried", Vec3(1000, 1000, 310)};  // 10 m above, h_safe 20 m
  r = plan_initial_path(grid, buried_start, {NamedPoint{"t-ok", Vec3(1800, 1800, 100)}});
  EXPECT_EQ(r.status, PathStatus::kInvalidInput);
  EXPECT_EQ(r.failed_point, "uav-buried");
  EXPECT_NE(r.message.find("'uav-buried'"), std::string::npos) << r.message;

  r = plan_initial_path(grid, ok_start, {NamedPoint{"t-away", Vec3(2500, 100, 100)}});
  EXPECT_EQ(r.status, PathStatus::kInvalidInput);
  EXPECT_EQ(r.failed_point, "t-away");

  PathSearchOptions bad;
  bad.cell_size_m = -1.0;
  EXPECT_THROW(ClearanceGrid(terrain, SearchArea{}, world::SafetyLimits{}, bad), InputError);
}

// Random terrains like the default scenario (DESIGN §7): 6–8 peaks 80–300 m in 2 km × 2 km.
PeakTerrainConfig random_terrain(Rng& rng) {
  PeakTerrainConfig cfg;
  const int n = 6 + static_cast<int>(rng.uniform(0.0, 3.0));
  for (int k = 0; k < n; ++k) {
    cfg.peaks.push_back(Peak{rng.uniform(300, 1700), rng.uniform(300, 1700), rng.uniform(80, 300),
                             rng.uniform(100, 250), rng.uniform(100, 250)});
  }
  return cfg;
}

Vec3 random_point(Rng& rng, const PeakTerrain& terrain, double lo, double hi) {
  const double x = rng.uniform(lo, hi), y = rng.uniform(lo, hi);
  const double z = std::min(480.0, std::max(40.0, terrain.height(x, y) + rng.uniform(30.0, 150.0)));
  return Vec3(x, y, z);
}

TEST(PathSearch, RandomTerrainPathsKeepClearanceAndPitchWhenDenselyChecked) {
  Rng rng(42);
  PathSearchOptions o;
  o.cell_size_m = 20.0;
  int found = 0;
  double worst_leg_ms = 0.0;
  const int trials = 20;
  for (int trial = 0; trial < trials; ++trial) {
    const PeakTerrain terrain(random_terrain(rng));
    const ClearanceGrid grid(terrain, SearchArea{}, world::SafetyLimits{}, o);
    const NamedPoint start{"uav", random_point(rng, terrain, 50, 400)};
    std::vector<NamedPoint> targets{{"a", random_point(rng, terrain, 1200, 1950)},
                                    {"b", random_point(rng, terrain, 900, 1950)}};
    const PathResult r = plan_initial_path(grid, start, targets);
    if (r.status != PathStatus::kFound) {
      // The only acceptable failure is a named target whose approach is steeper than θ_max.
      EXPECT_EQ(r.status, PathStatus::kUnreachable) << r.message;
      std::printf("not found: %s\n", r.message.c_str());
      EXPECT_FALSE(r.failed_point.empty());
      continue;
    }
    ++found;
    worst_leg_ms = std::max(worst_leg_ms, r.search_time_ms / 2.0);
    ASSERT_EQ(r.target_waypoint_index.size(), 2u);
    EXPECT_EQ(r.waypoints_m[r.target_waypoint_index[0]], targets[0].position_m);
    EXPECT_EQ(r.waypoints_m.back(), targets[1].position_m);
    expect_path_safe(terrain, o, r);
  }
  std::printf("random terrains: %d/%d found, worst time per leg %.1f ms\n", found, trials,
              worst_leg_ms);
  // Targets sit 30–150 m above ground, so a steep-approach failure is rare.
  EXPECT_GE(found, trials - 2);
}

TEST(PathSearch, SteepHeightChangeGetsLoiterLoopsWithinPitchLimit) {
  // Two targets 60 m apart horizontally but 250 m apart in height: tan 30° × 60 m ≈ 35 m, so the
  // descent needs ≈ 433 m of horizontal path, which only loiter loops can provide.
  const PeakTerrain flat(PeakTerrainConfig{});
  const PathSearchOptions o;
  const ClearanceGrid grid(flat, SearchArea{}, world::SafetyLimits{}, o);
  const NamedPoint start{"uav0", Vec3(200, 200, 100)};
  const std::vector<NamedPoint> targets{{"high", Vec3(1000, 1000, 400)},
                                        {"low", Vec3(1060, 1000, 150)}};
  const PathResult r = plan_initial_path(grid, start, targets);
  ASSERT_EQ(r.status, PathStatus::kFound) << r.message;
  expect_path_safe(flat, o, r);
  double horizontal = 0.0;
  for (int k = r.target_waypoint_index[0]; k < r.target_waypoint_index[1]; ++k) {
    horizontal += (r.waypoints_m[k + 1] - r.waypoints_m[k]).head<2>().norm();
  }
  EXPECT_GE(horizontal, 250.0 / std::tan(o.max_pitch_rad) - 1e-6);
}

TEST(PathSearch, TenMetreCellsOverTwoKilometresIsFast) {
  Rng rng(7);
  PathSearchOptions o;
  o.cell_size_m = 10.0;
  const PeakTerrain terrain(wall_terrain());
  const ClearanceGrid grid(terrain, SearchArea{}, world::SafetyLimits{}, o);
  const PathResult r = plan_initial_path(grid, NamedPoint{"uav0", Vec3(50, 50, 100)},
                                         {NamedPoint{"t0", Vec3(1950, 100, 100)}});
  ASSERT_EQ(r.status, PathStatus::kFound) << r.message;
  expect_path_safe(terrain, o, r);
  std::printf(
      "10 m cells, 200x200 grid: grid build %.1f ms, leg %.1f ms, %d nodes expanded, %zu "
      "waypoints, length %.0f m\n",
      grid.build_time_ms(), r.search_time_ms, r.nodes_expanded, r.waypoints_m.size(), r.length_m);
  // Timing is reported, not asserted (STYLE.md: wall-clock never gates CI); the search must not
  // expand more cells than the grid has.
  EXPECT_LE(r.nodes_expanded, grid.rows() * grid.cols());

  // Default-scenario-like terrains, south-west corner to north-east corner.
  double worst_ms = 0.0, worst_build_ms = 0.0;
  for (int trial = 0; trial < 5; ++trial) {
    const PeakTerrain random(random_terrain(rng));
    const ClearanceGrid g(random, SearchArea{}, world::SafetyLimits{}, o);
    const PathResult leg =
        plan_initial_path(g, NamedPoint{"uav0", random_point(rng, random, 50, 200)},
                          {NamedPoint{"t0", random_point(rng, random, 1800, 1950)}});
    ASSERT_EQ(leg.status, PathStatus::kFound) << leg.message;
    expect_path_safe(random, o, leg);
    worst_ms = std::max(worst_ms, leg.search_time_ms);
    worst_build_ms = std::max(worst_build_ms, g.build_time_ms());
  }
  std::printf("10 m cells, random 6-8 peak terrains: worst grid build %.1f ms, worst leg %.1f ms\n",
              worst_build_ms, worst_ms);
}

}  // namespace
}  // namespace ridgeline::planning
