// Deterministic planning problems of any team size, shared by the tests, the benchmarks and
// `ridgeline bench plan` (nothing random: the same call gives the same problem).
//
//  - default_like_terrain(): a 2 km × 2 km peak field like the default scenario's (DESIGN §7:
//    7 peaks 80–300 m high), for tests that do not load a scenario file;
//  - lifted_line() and straight_line_team(): initial guesses for the trajectory optimizer that
//    do not depend on the path search (straight lines lifted above the terrain);
//  - scaled_team(): a global planning problem grown from a base problem (e.g. the default
//    scenario's) to any number of UAVs and targets on the same terrain and area.
#pragma once

#include <vector>

#include "core/types.hpp"
#include "planning/global_planner.hpp"
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

/// `base` grown (or cut) to `uav_count` UAVs and as many targets. The first UAVs and targets are
/// the base's; extra UAVs copy the first UAV's vehicle and start in a launch field around the
/// base starts: a lattice of spacing max(30 m, 2·d_safe) aligned with the first UAV's heading,
/// filled ring by ring outward from the base starts' centroid, inside the area (20 m inset) and
/// a spacing away from every other start, at the base start altitude or h_safe + 10 m above the
/// terrain if that is higher; extra targets fill a lattice
/// over the bounding box of the base targets grown to ≥ 700 m, ≥ 40 m from every other target,
/// h_safe + 40 m above the terrain (and within the altitude band), priority 1.
/// Throws InputError (field "uav_count" or "base") when that cannot be done.
GlobalPlanningProblem scaled_team(const GlobalPlanningProblem& base, int uav_count);

}  // namespace ridgeline::planning
