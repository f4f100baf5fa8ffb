// Reading and writing DEM rasters with GDAL (DESIGN §4, §8): GeoTIFF, ESRI ASCII grid (.asc),
// SRTM .hgt, and anything else GDAL opens as a single-band north-up raster.
//
// Two levels:
// - read_dem: the raw raster in the DEM's OWN coordinates (CRS units, degrees if geographic)
//   plus its CRS.
// - load_dem_in_frame: with a geodetic origin (io/geo_frame.hpp), the DEM in ANY CRS GDAL
//   knows (EPSG:4326 SRTM, UTM, an ESRI grid with a .prj, ...) warped by GDAL/PROJ into the
//   origin's local transverse Mercator frame (bilinear resampling); heights stay the DEM's
//   (above mean sea level).
// - load_dem_local: without an origin, the rule "local = DEM projected coordinates minus the
//   raster's south-west CORNER", i.e. local (0, 0) is the DEM's south-west corner and the
//   south-west cell's centre sits at (Δx/2, Δy/2). A DEM whose CRS is geographic is rejected
//   there (it needs a geodetic origin): degrees are never read as metres.
//
// Grid conventions are those of world/raster_grid.hpp (cell-centre samples, row 0 south).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "io/geo_frame.hpp"
#include "world/mapped_raster_terrain.hpp"
#include "world/raster_grid.hpp"

namespace ridgeline::io {

/// A void of the DEM (no-data cells, 8-connected) and what filling it added. The filled heights
/// are the rim's mean spread inwards PLUS the rim's height range (margin_m): a void can hide a
/// peak, and no more than its rim says is known about it, so the fill stands at least as high
/// as the highest rim cell and every clearance over it keeps that margin.
struct VoidRegion {
  int cells = 0;
  /// Extent of the void's cell centres in the DEM's own coordinates (degrees if geographic).
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
  double rim_min_m = 0.0;
  double rim_max_m = 0.0;
  double margin_m = 0.0;  ///< rim_max_m − rim_min_m, added to every filled height
};

struct DemRaster {
  /// Heights in metres. Spatial fields in the CRS's units: origin_x_m/origin_y_m is the
  /// south-west cell centre and cell_x_m/cell_y_m the spacing — in DEGREES when is_geographic
  /// (despite the `_m` names), in the CRS's linear unit otherwise (see linear_unit_m).
  world::RasterGrid grid;
  std::string path;
  std::string driver;   ///< GDAL driver short name, e.g. "GTiff", "AAIGrid", "SRTMHGT"
  std::string crs_wkt;  ///< empty when the file has no CRS
  bool has_crs = false;
  bool is_geographic = false;  ///< CRS in angular units (lon/lat degrees)
  double linear_unit_m = 1.0;  ///< metres per projected CRS unit (1 for metres)
  bool has_nodata = false;
  double nodata_value = 0.0;
  int voids_filled = 0;  ///< nodata cells filled from their valid neighbours
  std::vector<VoidRegion> void_regions;  ///< every void, as filled
  /// The vertical datum the file's CRS names (a compound CRS's vertical part), or empty.
  std::string vertical_datum;
  std::vector<char> void_mask;           ///< rows·cols, 1 where the DEM had no data
};

/// Reads band 1 of `path`. Voids (the band's nodata value, or non-finite values) are filled
/// by repeated passes that set every void with at least one valid 8-neighbour to the mean of
/// those neighbours (isolated voids take their neighbours' mean; larger holes fill from their
/// rim inwards), then raised by their rim's height range (VoidRegion); the count is in
/// voids_filled.
/// Throws InputError naming the file when it is missing or unreadable, has no geotransform,
/// is rotated or not north-up, has more than half its cells void, or heights in a unit other
/// than metres or feet (feet are converted).
DemRaster read_dem(const std::filesystem::path& path);

/// The DEM in the local frame (see above). Throws InputError naming the file when its CRS is
/// geographic, or when it has no CRS but its coordinates look like degrees (cell < 0.002
/// units and the extent inside ±180 × ±90), so an unlabeled SRTM tile is not read as metres.
/// A file with no CRS is otherwise taken as metres.
world::RasterGrid load_dem_local(const std::filesystem::path& path);
/// The same conversion for an already read raster.
world::RasterGrid to_local_frame(const DemRaster& dem);

/// A rectangle of the local frame, in metres.
struct LocalWindow {
  double x_min_m = 0.0, x_max_m = 0.0, y_min_m = 0.0, y_max_m = 0.0;
};

/// The DEM warped into `frame` (see above). The output grid is GDAL's suggested one for the
/// warp (about the source's resolution, square cells in metres); cells whose centre falls
/// outside the source footprint (the corners of a footprint rotated by the meridian
/// convergence) are trimmed away row by row and column by column from the border, so every
/// height is interpolated from real data, never extrapolated. Throws InputError naming the
/// file when it has no CRS (it cannot be placed), when GDAL/PROJ cannot transform it, or when
/// nothing is left.
/// With `window` only the DEM around that rectangle of the local frame (plus two cells) is
/// warped, so a large tile around a small mission area costs little; the result may then not
/// cover the window where the DEM itself does not.
world::RasterGrid load_dem_in_frame(const std::filesystem::path& path, const GeoFrame& frame,
                                    const std::optional<LocalWindow>& window = std::nullopt);
/// The same warp for an already read raster.
world::RasterGrid warp_to_frame(const DemRaster& dem, const GeoFrame& frame,
                                const std::optional<LocalWindow>& window = std::nullopt);

/// The DEM in its own coordinates and the map that carries the local frame onto them
/// (world/mapped_raster_terrain.hpp): no resampling, so every height is the DEM's own bilinear
/// interpolation on its pixels.
struct MappedDem {
  world::RasterGrid source;       ///< the DEM cut to the area (plus a margin), its own coordinates
  world::CoordinateMap map;       ///< local frame → the DEM's coordinates, on a 50 m lattice
  double map_error_m = 0.0;       ///< height bound of the map's interpolation error
  std::vector<VoidRegion> voids;  ///< the voids that reach into the cut
  int void_cells_in_area = 0;     ///< DEM cells under the area that were void
  int cells_in_area = 0;          ///< DEM cells under the area
};

/// Cuts the DEM to `window` of `frame` (plus a margin) and maps the window onto it with
/// GDAL/PROJ. Throws InputError naming the file when it has no CRS, when PROJ cannot transform
/// it, or when the window reaches beyond the DEM's cells (heights there would be invented).
MappedDem map_to_frame(const DemRaster& dem, const GeoFrame& frame, const LocalWindow& window);

/// Writes `grid` as a Float64 GeoTIFF in EPSG:`epsg`; the grid's coordinates are taken to be
/// in that CRS (south-west cell centre = origin, see raster_grid.hpp). Throws InputError on an
/// unknown EPSG code, a bad grid or a failed write.
void write_dem_geotiff(const std::filesystem::path& path, const world::RasterGrid& grid, int epsg);

/// Writes `grid` as an ESRI ASCII grid (no CRS, no .prj) with 17 significant digits, so
/// heights round-trip exactly. ESRI grids have square cells; unequal cell sizes are written
/// with GDAL's DX/DY extension, which GDAL reads back.
void write_dem_ascii_grid(const std::filesystem::path& path, const world::RasterGrid& grid);

}  // namespace ridgeline::io
