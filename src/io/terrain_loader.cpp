#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "io/dem_file.hpp"
#include "io/geo_frame.hpp"
#include "io/scenario_file.hpp"
#include "world/terrain.hpp"
#include "world/terrain_fit.hpp"

namespace ridgeline::io {

namespace {

// The DEM must cover the operating area: beyond its cells the raster clamps and a fitted
// field extrapolates, so any height there would be invented. Half a cell of slack is the
// raster's own cell area (raster_grid.hpp).
void check_area_inside(const world::RasterGrid& grid, const mission::Area& area,
                       const std::string& dem_path) {
  const double west = grid.origin_x_m - 0.5 * grid.cell_x_m;
  const double south = grid.origin_y_m - 0.5 * grid.cell_y_m;
  const double east = grid.x_of_col(grid.cols - 1) + 0.5 * grid.cell_x_m;
  const double north = grid.y_of_row(grid.rows - 1) + 0.5 * grid.cell_y_m;
  const double tol =
      1e-6 * std::max({1.0, std::abs(west), std::abs(east), std::abs(south), std::abs(north)});
  if (area.x_min_m < west - tol || area.x_max_m > east + tol || area.y_min_m < south - tol ||
      area.y_max_m > north + tol) {
    throw InputError("area", fmt::format("x [{}, {}], y [{}, {}] m reaches beyond the DEM '{}', "
                                         "which covers x [{:.1f}, {:.1f}], y [{:.1f}, {:.1f}] m "
                                         "in the local frame: terrain heights there would be "
                                         "invented; shrink the area or use a larger DEM",
                                         area.x_min_m, area.x_max_m, area.y_min_m, area.y_max_m,
                                         dem_path, west, east, south, north));
  }
}

}  // namespace

std::shared_ptr<const world::Terrain> build_terrain(
    const mission::TerrainSource& source, const std::optional<mission::GeodeticOrigin>& origin,
    const mission::Area* area) {
  if (source.kind == mission::TerrainSource::Kind::kPeaks)
    return std::make_shared<world::PeakTerrain>(source.peaks, "terrain");

  world::RasterGrid grid;
  try {
    std::optional<LocalWindow> window;
    // A malformed area is reported by validation; it only narrows the warp when usable.
    if (area != nullptr && area->x_min_m < area->x_max_m && area->y_min_m < area->y_max_m &&
        std::isfinite(area->x_min_m + area->x_max_m + area->y_min_m + area->y_max_m))
      window = LocalWindow{area->x_min_m, area->x_max_m, area->y_min_m, area->y_max_m};
    grid = origin ? load_dem_in_frame(source.dem_path, GeoFrame(*origin), window)
                  : load_dem_local(source.dem_path);
  } catch (const InputError& e) {
    // The file's own error says what is wrong with it; the field says where it was named.
    throw InputError("terrain.dem.path", e.what());
  }
  if (area != nullptr) check_area_inside(grid, *area, source.dem_path);
  if (source.dem_model == mission::TerrainSource::DemModel::kRaster)
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
