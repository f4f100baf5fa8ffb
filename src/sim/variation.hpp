// Randomized variations of a scenario for Monte Carlo runs (issue "main job", part 7): what
// changes from flight to flight while the ground station's plan stays the same.
//
// From one variation seed: each sudden threat's path (centre ±threat_shift_m horizontally,
// ±threat_shift_m/3 vertically, each horizontal velocity component ±threat_speed_m_s) and
// times (appearance ±threat_time_s, same lifetime); the wind (another gust realisation, the
// mean rotated by ±wind_direction_rad and scaled by 1 ± wind_speed_fraction); the sensor
// noise (another seed for position fixes and anemometers); and each UAV's start (±start_jitter_m
// horizontally, heading ±start_heading_rad). A start jitter that would break the scenario's
// own checks (clearance, separation of starts) is drawn again, up to 20 times, then dropped.
// The plan is not re-made: a vehicle is never exactly where its plan starts.
#pragma once

#include <cstdint>

#include "mission/scenario.hpp"
#include "world/terrain.hpp"

namespace ridgeline::sim {

struct VariationOptions {
  double threat_shift_m = 60.0;
  double threat_speed_m_s = 1.5;
  double threat_time_s = 15.0;
  double wind_direction_rad = deg_to_rad(30.0);
  double wind_speed_fraction = 0.25;
  double start_jitter_m = 5.0;
  double start_heading_rad = deg_to_rad(10.0);
};

/// The scenario as flown in variation `variation_seed`; scenario.seed becomes that seed.
mission::Scenario vary_scenario(const mission::Scenario& scenario, const world::Terrain& terrain,
                                std::uint64_t variation_seed, const VariationOptions& options = {});

/// The seed of run `index` of a Monte Carlo batch on a scenario (replayable with
/// `ridgeline run --variation SEED`).
std::uint64_t variation_seed(const mission::Scenario& scenario, int index);

}  // namespace ridgeline::sim
