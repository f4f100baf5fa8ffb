#include "world/safety_limits.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/error.hpp"

namespace ridgeline::world {

std::string_view to_string(AltitudeDatum datum) {
  switch (datum) {
    case AltitudeDatum::kTerrainDatum:
      return "terrain datum";
    case AltitudeDatum::kMeanSeaLevel:
      return "mean sea level";
  }
  return "unknown";
}

void validate(const SafetyLimits& limits) {
  const auto finite = [](const char* field, double value) {
    if (!std::isfinite(value))
      throw InputError(field, fmt::format("must be a finite number, got {}", value));
  };
  finite("safety.terrain_clearance_m", limits.terrain_clearance_m);
  finite("safety.separation_m", limits.separation_m);
  finite("safety.threat_margin_m", limits.threat_margin_m);
  finite("altitude.min_m", limits.altitude.min_m);
  finite("altitude.max_m", limits.altitude.max_m);
  if (limits.terrain_clearance_m < 0.0)
    throw InputError("safety.terrain_clearance_m",
                     fmt::format("must not be negative, got {}", limits.terrain_clearance_m));
  if (limits.separation_m <= 0.0)
    throw InputError("safety.separation_m",
                     fmt::format("must be positive, got {}", limits.separation_m));
  if (limits.threat_margin_m < 0.0)
    throw InputError("safety.threat_margin_m",
                     fmt::format("must not be negative, got {}", limits.threat_margin_m));
  if (!(limits.altitude.min_m < limits.altitude.max_m))
    throw InputError("altitude.min_m", fmt::format("{} must be below altitude.max_m ({})",
                                                   limits.altitude.min_m, limits.altitude.max_m));
}

}  // namespace ridgeline::world
