// The file `ridgeline fit-dem` writes: a fitted peak terrain (eq. 12) plus the fit's report.
//
// Schema (the scenario parser reads the `terrain` part via `terrain: {include: FILE}`):
//   terrain:
//     combination: max          # max | sum
//     base_elevation_m: 12.5
//     model_error_m: 3.2        # max residual of the fit
//     peaks:
//       - {x_m: 500, y_m: 600, height_m: 250, sigma_x_m: 150, sigma_y_m: 200}
//   fit_report: {dem: FILE, rmse_m: .., max_residual_m: .., iterations: .., time_s: ..,
//                raster_cols: .., raster_rows: ..}
// Lengths are in the local ENU frame of the DEM (load_dem_local in dem_file.hpp), or, when the
// fit was made around a geodetic origin (fit-dem --origin), in that origin's frame
// (io/geo_frame.hpp), which fit_report.origin {lat_deg, lon_deg, alt_amsl_m} then records; a
// scenario including the file must name the same origin.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "mission/scenario.hpp"
#include "world/raster_grid.hpp"
#include "world/terrain_fit.hpp"

namespace ridgeline::io {

/// The YAML text of a fit of the DEM at `dem_path` (its raster `grid` gives cols and rows).
std::string terrain_fit_yaml(const world::TerrainFitResult& fit, const std::string& dem_path,
                             const world::RasterGrid& grid,
                             const std::optional<mission::GeodeticOrigin>& origin = std::nullopt);

/// Writes terrain_fit_yaml atomically (FILE.tmp, then rename): on error no partial file is
/// left. Throws InputError naming `path` when it cannot be written.
void write_terrain_fit_yaml(const std::filesystem::path& path, const world::TerrainFitResult& fit,
                            const std::string& dem_path, const world::RasterGrid& grid,
                            const std::optional<mission::GeodeticOrigin>& origin = std::nullopt);

}  // namespace ridgeline::io
