#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>
#include <vector>

#include "io/dem_file.hpp"
#include "io/geo_frame.hpp"
#include "io/scenario_file.hpp"
#include "world/mapped_raster_terrain.hpp"
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

// Which vertical datum the heights are in, and why that is known: the DEM's CRS, the
// scenario's statement (which must agree with the DEM's when both exist), or the assumption.
std::string vertical_datum(const DemRaster& dem, const mission::TerrainSource& source,
                           bool has_origin) {
  const std::string& stated = source.dem_vertical_datum;
  // Names compare as lower-case alphanumeric words: "egm96" matches "EGM96 geoid", "EGM" does
  // not match "EGM2008", and a statement may also spell the DEM's whole name.
  auto words = [](const std::string& text) {
    std::vector<std::string> out(1);
    for (const char ch : text) {
      if (std::isalnum(static_cast<unsigned char>(ch)))
        out.back() += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      else if (!out.back().empty())
        out.emplace_back();
    }
    if (out.back().empty()) out.pop_back();
    return out;
  };
  if (!dem.vertical_datum.empty()) {
    const std::vector<std::string> declared = words(dem.vertical_datum), said = words(stated);
    const bool agrees = said.empty() || said == declared ||
                        (said.size() == 1 && std::find(declared.begin(), declared.end(),
                                                       said.front()) != declared.end());
    if (!agrees)
      throw InputError("terrain.dem.vertical_datum",
                       fmt::format("'{}' disagrees with the DEM's own vertical datum '{}' ({}): "
                                   "convert the DEM or correct the statement",
                                   stated, dem.vertical_datum, dem.path));
    return dem.vertical_datum + " (from the DEM's CRS)";
  }
  if (!stated.empty()) return stated + " (stated in the scenario)";
  const std::string origin_note =
      has_origin ? "; the origin's alt_amsl_m and every altitude are taken in the same datum" : "";
  if (dem.driver == "SRTMHGT")
    return "EGM96 geoid (assumed: SRTM heights are above EGM96; the file does not say)" +
           origin_note;
  return "not stated by the DEM or the scenario: heights as the DEM gives them (set "
         "dem.vertical_datum, e.g. EGM96 for SRTM)" +
         origin_note;
}

}  // namespace

std::shared_ptr<const world::Terrain> build_terrain(
    const mission::TerrainSource& source, const std::optional<mission::GeodeticOrigin>& origin,
    const mission::Area& area, TerrainReport* report) {
  TerrainReport local_report;
  TerrainReport& r = report != nullptr ? *report : local_report;
  if (source.kind == mission::TerrainSource::Kind::kPeaks) {
    auto terrain = std::make_shared<world::PeakTerrain>(source.peaks, "terrain");
    r.model = "peaks (eq. 12)";
    r.vertical_datum = "the scenario's terrain datum (peaks)";
    r.error_bound_m = terrain->model_error_m();
    return terrain;
  }

  const bool raster = source.dem_model == mission::TerrainSource::DemModel::kRaster;
  // A malformed area is reported by validation; it only narrows the DEM when usable.
  const bool area_usable = area.x_min_m < area.x_max_m && area.y_min_m < area.y_max_m &&
                           std::isfinite(area.x_min_m + area.x_max_m + area.y_min_m + area.y_max_m);
  const LocalWindow window{area.x_min_m, area.x_max_m, area.y_min_m, area.y_max_m};
  std::shared_ptr<const world::Terrain> terrain;
  world::RasterGrid grid;  // the local grid the fitted model is fitted to
  try {
    const DemRaster dem = read_dem(source.dem_path);
    r.void_units = dem.is_geographic ? "deg" : "CRS units";
    r.vertical_datum = vertical_datum(dem, source, origin.has_value());
    if (origin) {
      const GeoFrame frame(*origin);
      if (area_usable) {
        MappedDem mapped = map_to_frame(dem, frame, window);
        r.voids = mapped.voids;
        r.void_cells_in_area = mapped.void_cells_in_area;
        r.cells_in_area = mapped.cells_in_area;
        if (raster)
          terrain = std::make_shared<world::MappedRasterTerrain>(
              std::move(mapped.source), std::move(mapped.map), mapped.map_error_m,
              "terrain.dem.path");
      }
      if (!terrain) {
        grid = warp_to_frame(dem, frame, area_usable ? std::optional(window) : std::nullopt);
        if (area_usable) check_area_inside(grid, area, source.dem_path);
      }
      r.model = raster && terrain
                    ? "dem raster on its own pixels, mapped into the local frame by PROJ"
                    : "dem warped into the local frame (bilinear)";
    } else {
      grid = to_local_frame(dem);
      if (area_usable) check_area_inside(grid, area, source.dem_path);
      r.model = "dem raster on its own pixels";
      r.voids = dem.void_regions;
      // Local frame = the DEM's coordinates shifted: count the cells under the area.
      for (int row = 0; row < grid.rows; ++row)
        for (int col = 0; col < grid.cols; ++col) {
          const double x = grid.x_of_col(col), y = grid.y_of_row(row);
          if (x < area.x_min_m - 0.5 * grid.cell_x_m || x > area.x_max_m + 0.5 * grid.cell_x_m ||
              y < area.y_min_m - 0.5 * grid.cell_y_m || y > area.y_max_m + 0.5 * grid.cell_y_m)
            continue;
          ++r.cells_in_area;
          if (!dem.void_mask.empty() &&
              dem.void_mask[static_cast<std::size_t>(row) * grid.cols + col])
            ++r.void_cells_in_area;
        }
    }
  } catch (const InputError& e) {
    if (e.field() == "area" || e.field() == "origin" || e.field() == "terrain.dem.path" ||
        e.field() == "terrain.dem.vertical_datum")
      throw;
    // The file's own error says what is wrong with it; the field says where it was named.
    throw InputError("terrain.dem.path", e.what());
  }
  if (r.cells_in_area > 0 &&
      r.void_cells_in_area > kMaxVoidShareInArea * static_cast<double>(r.cells_in_area))
    throw InputError(
        "terrain.dem.path",
        fmt::format("'{}': {} of the {} DEM cells under the area are void (no data), "
                    "{:.1f} %, more than the {:.0f} % a filled DEM may have there: "
                    "a filled void can hide a peak; use a void-filled DEM product",
                    source.dem_path, r.void_cells_in_area, r.cells_in_area,
                    100.0 * r.void_cells_in_area / r.cells_in_area, 100.0 * kMaxVoidShareInArea));
  if (terrain) {
    r.error_bound_m = terrain->model_error_m();
    return terrain;
  }
  if (raster) {
    terrain = std::make_shared<world::RasterTerrain>(std::move(grid), 0.0, "terrain.dem.path");
    r.error_bound_m = terrain->model_error_m();
    return terrain;
  }

  world::TerrainFitOptions options;
  options.num_peaks = source.dem_fit_peaks;
  options.combination = source.dem_fit_combination;
  const world::TerrainFitResult fit = world::fit_peak_terrain(grid, options);
  if (fit.status == world::TerrainFitStatus::kFailed) {
    throw InputError("terrain.dem",
                     fmt::format("fitting {} peaks to '{}' failed: {}", source.dem_fit_peaks,
                                 source.dem_path, fit.message));
  }
  // The fit's max residual travels with the field (model_error_m) and is added to every
  // terrain clearance check.
  r.model = fmt::format("{} peaks fitted to the {}", source.dem_fit_peaks, r.model);
  terrain = std::make_shared<world::PeakTerrain>(fit.terrain, "terrain");
  r.error_bound_m = terrain->model_error_m();
  return terrain;
}

}  // namespace ridgeline::io
