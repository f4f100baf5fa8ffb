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
#include "mission/scenario.hpp"
#include "world/terrain.hpp"

namespace ridgeline::io {

/// A parsed, validated scenario and the terrain it describes.
struct LoadedScenario {
  mission::Scenario scenario;
  std::shared_ptr<const world::Terrain> terrain;
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
/// origin a DEM in any CRS is warped into the origin's local frame (io/geo_frame.hpp);
/// without one, a DEM in degrees is an error. With `area`, a DEM that does not cover it is an
/// error naming `area` (heights beyond a DEM would be invented).
std::shared_ptr<const world::Terrain> build_terrain(
    const mission::TerrainSource& source,
    const std::optional<mission::GeodeticOrigin>& origin = std::nullopt,
    const mission::Area* area = nullptr);

/// Parses, builds the terrain and validates. Throws InputError (or InvalidScenario).
LoadedScenario load_scenario(const std::string& yaml_text, const std::string& source,
                             const std::filesystem::path& base_dir);
LoadedScenario load_scenario_file(const std::filesystem::path& path);
LoadedScenario load_default_scenario();

}  // namespace ridgeline::io
