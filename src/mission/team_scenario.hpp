// A scenario for a team of any size (issue 20, `ridgeline scenario team`): a base scenario's
// terrain, area, vehicle, limits and parameters with N UAVs on a take-off grid, M targets spread
// over the area and threats at the base's density, all drawn from one seed.
//
//  - Take-off grid: an axis-aligned lattice of spacing max(30 m, d_safe + 5 m) in the area's
//    south-west corner (50 m inset), ⌈√N⌉ columns (fewer rows than columns when the area is
//    narrow); each start h_safe + 20 m above the terrain (at least H_min + 20 m), heading to the
//    area's centre, at the base UAV's speed and sensor range. More UAVs than the lattice holds
//    inside the area is an error.
//  - Targets: uniform over the area (100 m inset), not within 300 m of the take-off field, at
//    least 60 m apart (relaxed down to 2·d_safe when the area is crowded), 20–60 m above the
//    clearance floor (h_safe plus the terrain's model error) and inside the altitude band
//    (10 m below H_max); priority 2 for one in five, else 1.
//  - Threats: the default scenario's density (3 on 4 km²) unless a count is given; each
//    a sphere of radius 35–50 m, 60–130 m above the clearance floor, moving at 3.5–6.5 m/s in a
//    random horizontal direction, appearing at 20–120 s for 150–230 s, never starting within
//    300 m of the take-off field.
// Nothing else changes: the result is validated like any scenario by the loader.
#pragma once

#include <cstdint>

#include "mission/scenario.hpp"
#include "world/terrain.hpp"

namespace ridgeline::mission {

struct TeamScenarioOptions {
  int uavs = 0;            ///< N ≥ 1
  int targets = 0;         ///< M ≥ 1
  std::uint64_t seed = 1;  ///< the targets', threats' and the scenario's seed
  int threats = -1;        ///< ≥ 0; −1: threats_per_km2 × the area
  /// The default scenario's density: 3 threats on its 2 km × 2 km.
  double threats_per_km2 = 0.75;
};

/// The take-off lattice's spacing for the limits: max(30 m, d_safe + 5 m).
double takeoff_spacing_m(const world::SafetyLimits& limits);

/// The team scenario (file comment). Throws InputError with field "uavs" (count < 1, more than
/// the take-off grid holds, a take-off field outside the band), "targets" (count < 1, no room)
/// or "threats".
Scenario make_team_scenario(const Scenario& base, const world::Terrain& terrain,
                            const TeamScenarioOptions& options);

}  // namespace ridgeline::mission
