#include <fmt/format.h>

#include "io/dem_file.hpp"
#include "io/geo_frame.hpp"
#include "io/scenario_file.hpp"
#include "world/terrain.hpp"
#include "world/terrain_fit.hpp"

namespace ridgeline::io {

std::shared_ptr<const world::Terrain> build_terrain(
    const sim::TerrainSource& source, const std::optional<sim::GeodeticOrigin>& origin) {
  if (source.kind == sim::TerrainSource::Kind::kPeaks)
    return std::make_shared<world::PeakTerrain>(source.peaks, "terrain");

  world::RasterGrid grid;
  try {
    grid = origin ? load_dem_in_frame(source.dem_path, GeoFrame(*origin))
                  : load_dem_local(source.dem_path);
  } catch (const InputError& e) {
    // The file's own error says what is wrong with it; the field says where it was named.
    throw InputError("terrain.dem.path", e.what());
  }
  if (source.dem_model == sim::TerrainSource::DemModel::kRaster)
    return std::make_shared<world::RasterTerrain>(std::move(grid), 0.0, "terrain.dem.path");

  world::TerrainFitOptions options;
  options.num_peaks = source.dem_fit_peaks;
  options.combination = source.dem_fit_combination;
  const world::TerrainFitResult fit = world::fit_peak_terrain(grid, options);
  if (fit.status == world::TerrainFitStatus::kFailed) {
    throw InputError("terrain.dem", fmt::format("fitting {} peaks to '{}' failed: {}",
                                                source.dem_fit_peaks, source.dem_path,
                                                fit.message));
  }
  // The fit's max residual travels with the field (model_error_m) and is added to every
  // terrain clearance check.
  return std::make_shared<world::PeakTerrain>(fit.terrain, "terrain");
}

}  // namespace ridgeline::io
