// Deterministic planning problems of any team size, shared by the tests, the benchmarks and
// `ridgeline bench plan` (nothing random: the same call gives the same problem).
//
//  - default_like_terrain(): a 2 km × 2 km peak field like the default scenario's (DESIGN §7:
//    7 peaks 80–300 m high), for tests that do not load a scenario file;
//  - lifted_line() and straight_line_team(): initial guesses for the trajectory optimizer that
//    do not depend on the path search (straight lines lifted above the terrain).
// Teams of scenario size are made by mission::make_team_scenario (`ridgeline scenario team`).
#pragma once

#include <vector>

#include "core/types.hpp"
#include "planning/trajectory_optimizer.hpp"
#include "world/terrain.hpp"

namespace ridgeline::planning {

world::PeakTerrain default_like_terrain(
    world::PeakCombination combination = world::PeakCombination::kMax);

/// A polyline from a to b with points every ≤ spacing_m (horizontally), lifted to at least
/// H + lift_m and H_min, and smoothed so the grade stays ≤ max_grade where the ends allow it
/// (a rough stand-in for the path search's profile). The ends stay exactly a and b.
std::vector<Vec3> lifted_line(const world::Terrain& terrain, const Vec3& a, const Vec3& b,
                              double spacing_m = 20.0, double lift_m = 35.0,
                              double min_altitude_m = 40.0, double max_grade = 0.25);

/// `count` UAVs starting side by side in the south-west (30 m apart on a diagonal, like the
/// default scenario; rows of 10) with one target each spread over the north-east, 40 m above
/// the terrain, joined by lifted_line. `terrain` must outlive the problem.
TrajectoryProblem straight_line_team(const world::Terrain& terrain, int count);

}  // namespace ridgeline::planning
