// Scenario files (YAML) and the embedded default scenario (DESIGN §7).
//
// The format is the one `ridgeline scenario default` prints, with comments on every field.
// Loading parses, builds the terrain (inline peaks, a DEM raster, or a peak field fitted to
// a DEM) and validates everything against it; any problem is an InputError naming the field.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.hpp"
#include "io/dem_file.hpp"
#include "mission/scenario.hpp"
#include "world/terrain.hpp"

namespace ridgeline::io {

/// A parsed, validated scenario and the terrain it describes.
/// What the terrain model is and how far it may stand from the source data: `validate`
/// prints it, summary.json carries it.
struct TerrainReport {
  std::string model;              ///< e.g. "dem raster on its own pixels, mapped by PROJ"
  double error_bound_m = 0.0;     ///< the terrain's model_error_m(), added to every clearance
  std::string void_units;         ///< of the voids' extents: "deg" or the DEM's CRS unit
  std::vector<VoidRegion> voids;  ///< the DEM's voids that reach the area, as filled
  int void_cells_in_area = 0;
  int cells_in_area = 0;
  /// The heights' vertical datum and where that comes from (the DEM's CRS, the scenario's
  /// `dem.vertical_datum`, or an assumption the run states).
  std::string vertical_datum;
};

/// The share of the DEM's cells under the area that may be void (no data): more is an error
/// naming terrain.dem.path. A filled void keeps its rim's height range as margin (VoidRegion).
constexpr double kMaxVoidShareInArea = 0.10;

struct LoadedScenario {
  mission::Scenario scenario;
  std::shared_ptr<const world::Terrain> terrain;
  TerrainReport terrain_report;
  std::string source;  ///< file path, or "<default>"
};

/// Thrown when a scenario parses but fails validation: what() names the first problem,
/// problems() lists every one.
class InvalidScenario : public InputError {
 public:
  explicit InvalidScenario(std::vector<InputError> problems);
  const std::vector<InputError>& problems() const { return problems_; }

 private:
  std::vector<InputError> problems_;
};

/// The embedded default scenario as commented YAML (the text of scenarios/default.yaml).
std::string_view default_scenario_yaml();

/// Parses scenario YAML into values, checking syntax, types, finiteness and keys (no
/// terrain-dependent checks). Relative file paths (DEM, include) resolve against base_dir.
mission::Scenario parse_scenario(const std::string& yaml_text, const std::string& source,
                                 const std::filesystem::path& base_dir);

/// Builds the terrain a scenario names (reading and possibly fitting its DEM). With a geodetic
/// origin a DEM in any CRS is placed in the origin's local frame (io/geo_frame.hpp): the
/// raster model is queried on the DEM's own pixels through PROJ's map
/// (world/mapped_raster_terrain.hpp), the fitted model is fitted to the DEM warped onto a
/// local grid. Without an origin, a DEM in degrees is an error. A DEM that does not cover
/// `area` is an error naming `area` (heights beyond a DEM would be invented); voids over more
/// than kMaxVoidShareInArea of it, one naming terrain.dem.path. `report`, when given, says
/// what was built.
std::shared_ptr<const world::Terrain> build_terrain(
    const mission::TerrainSource& source, const std::optional<mission::GeodeticOrigin>& origin,
    const mission::Area& area, TerrainReport* report = nullptr);

/// Parses, builds the terrain and validates. Throws InputError (or InvalidScenario).
LoadedScenario load_scenario(const std::string& yaml_text, const std::string& source,
                             const std::filesystem::path& base_dir);
LoadedScenario load_scenario_file(const std::filesystem::path& path);
LoadedScenario load_default_scenario();

}  // namespace ridgeline::io
