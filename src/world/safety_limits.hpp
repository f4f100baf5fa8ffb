// The mission's hard safety limits: the one owner of h_safe, d_safe, r_safe and the altitude
// band (DESIGN §5 eq. 14, 19–21; §3 the tracker's soft rows; eq. 13's threat margin).
//
// Built once from the scenario (mission/mission_inputs.hpp) and passed as a problem argument to
// every stage that enforces or reports a limit: the global planner and its stages, the local
// re-plan, the agents' detour and tracker, the comparison methods, the validators and the
// safety tally. No stage's Options struct carries a limit, so a limit cannot be set in one
// place and silently overwritten in another.
//
// The terrain model's known error (a fitted field's largest residual, a DEM's bound) belongs to
// the terrain (world::Terrain::model_error_m()); clearance_floor_m adds it, so every clearance
// enforced or reported is measured against h_safe plus the same error.
#pragma once

#include <string_view>

#include "world/terrain.hpp"

namespace ridgeline::world {

/// What the altitude band's z is measured from: the terrain model's datum (a scenario without a
/// geodetic origin) or mean sea level (with one; z is then metres AMSL).
enum class AltitudeDatum { kTerrainDatum, kMeanSeaLevel };
std::string_view to_string(AltitudeDatum datum);

/// The hard altitude band of eq. 14, in the frame's z.
struct AltitudeBand {
  double min_m = 40.0;   ///< H_min
  double max_m = 500.0;  ///< H_max
  AltitudeDatum datum = AltitudeDatum::kTerrainDatum;

  bool contains(double z_m, double tolerance_m = 0.0) const {
    return z_m >= min_m - tolerance_m && z_m <= max_m + tolerance_m;
  }
};

/// The limits, with the project's documented defaults (scenarios/default.yaml states the same
/// values; a scenario file that omits a field gets these).
struct SafetyLimits {
  double terrain_clearance_m = 20.0;  ///< h_safe, eq. 19–20: z − H(x, y) ≥ h_safe + model error
  double separation_m = 10.0;         ///< d_safe, eq. 21: between any two UAVs at equal times
  double threat_margin_m = 10.0;      ///< r_safe: kept outside a threat sphere's surface
  AltitudeBand altitude;              ///< eq. 14

  /// The least height above H(x, y) a point may have over `terrain`: h_safe + its model error.
  double clearance_floor_m(const Terrain& terrain) const {
    return terrain_clearance_m + terrain.model_error_m();
  }
};

/// Throws InputError naming the scenario field (`safety.separation_m`, `altitude.min_m`, ...)
/// when a limit is not finite, negative (d_safe: not positive) or the band is empty.
void validate(const SafetyLimits& limits);

}  // namespace ridgeline::world
