#include "io/dem_file.hpp"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <fmt/format.h>
#include <gdal_alg.h>
#include <gdal_priv.h>
#include <gdalwarper.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace ridgeline::io {

namespace {

void register_gdal() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

// GDAL reports errors through a global handler that prints to stderr; while one of our calls
// runs, errors are kept quiet and read back with CPLGetLastErrorMsg for our own message.
class QuietGdalErrors {
 public:
  QuietGdalErrors() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~QuietGdalErrors() { CPLPopErrorHandler(); }
  QuietGdalErrors(const QuietGdalErrors&) = delete;
  QuietGdalErrors& operator=(const QuietGdalErrors&) = delete;
};

std::string last_gdal_error() {
  const char* msg = CPLGetLastErrorMsg();
  return (msg != nullptr && *msg != '\0') ? std::string(msg) : std::string("no detail from GDAL");
}

struct DatasetCloser {
  void operator()(GDALDataset* ds) const {
    if (ds != nullptr) GDALClose(GDALDataset::ToHandle(ds));
  }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetCloser>;

// Sets a GDAL config option for this thread for the lifetime of the object.
class ScopedConfigOption {
 public:
  ScopedConfigOption(const char* key, const char* value) : key_(key) {
    const char* old = CPLGetThreadLocalConfigOption(key, nullptr);
    if (old != nullptr) old_ = old;
    had_old_ = old != nullptr;
    CPLSetThreadLocalConfigOption(key, value);
  }
  ~ScopedConfigOption() { CPLSetThreadLocalConfigOption(key_, had_old_ ? old_.c_str() : nullptr); }
  ScopedConfigOption(const ScopedConfigOption&) = delete;
  ScopedConfigOption& operator=(const ScopedConfigOption&) = delete;

 private:
  const char* key_;
  std::string old_;
  bool had_old_ = false;
};

// Metres per unit of a band's height unit string; < 0 for an unknown unit.
double height_unit_m(std::string unit) {
  std::transform(unit.begin(), unit.end(), unit.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (unit.empty() || unit == "m" || unit == "metre" || unit == "meter" || unit == "metres" ||
      unit == "meters") {
    return 1.0;
  }
  if (unit == "ft" || unit == "foot" || unit == "feet" || unit == "international foot")
    return 0.3048;
  if (unit == "us-ft" || unit == "us survey foot" || unit == "ftus") return 1200.0 / 3937.0;
  return -1.0;
}

// Fills void cells (marked in `is_void`) from the rim inwards: each pass sets every void with
// at least one valid 8-neighbour to the mean of those neighbours, using only values valid at
// the start of the pass so the result does not depend on scan order.
int fill_voids(world::RasterGrid& grid, std::vector<char>& is_void) {
  int filled = 0;
  std::vector<std::size_t> pending;
  std::vector<double> values;
  for (;;) {
    pending.clear();
    values.clear();
    for (int r = 0; r < grid.rows; ++r) {
      for (int c = 0; c < grid.cols; ++c) {
        const std::size_t k = static_cast<std::size_t>(r) * grid.cols + c;
        if (!is_void[k]) continue;
        double sum = 0.0;
        int count = 0;
        for (int i = std::max(0, r - 1); i <= std::min(grid.rows - 1, r + 1); ++i) {
          for (int j = std::max(0, c - 1); j <= std::min(grid.cols - 1, c + 1); ++j) {
            const std::size_t n = static_cast<std::size_t>(i) * grid.cols + j;
            if (!is_void[n]) {
              sum += grid.heights_m[n];
              ++count;
            }
          }
        }
        if (count > 0) {
          pending.push_back(k);
          values.push_back(sum / count);
        }
      }
    }
    if (pending.empty()) return filled;
    for (std::size_t i = 0; i < pending.size(); ++i) {
      grid.heights_m[pending[i]] = values[i];
      is_void[pending[i]] = 0;
    }
    filled += static_cast<int>(pending.size());
  }
}

// The voids of `mask` (8-connected), each raised by its rim's height range after fill_voids
// spread the rim inwards (dem_file.hpp, VoidRegion). Extents in the grid's own coordinates.
std::vector<VoidRegion> raise_filled_voids(world::RasterGrid& grid, const std::vector<char>& mask) {
  std::vector<VoidRegion> regions;
  std::vector<char> seen(mask.size(), 0);
  std::vector<std::size_t> component;
  for (std::size_t start = 0; start < mask.size(); ++start) {
    if (!mask[start] || seen[start]) continue;
    component.assign(1, start);
    seen[start] = 1;
    VoidRegion v;
    v.rim_min_m = std::numeric_limits<double>::infinity();
    v.rim_max_m = -std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < component.size(); ++i) {
      const int r = static_cast<int>(component[i] / grid.cols);
      const int c = static_cast<int>(component[i] % grid.cols);
      for (int rr = std::max(0, r - 1); rr <= std::min(grid.rows - 1, r + 1); ++rr)
        for (int cc = std::max(0, c - 1); cc <= std::min(grid.cols - 1, c + 1); ++cc) {
          const std::size_t n = static_cast<std::size_t>(rr) * grid.cols + cc;
          if (!mask[n]) {
            v.rim_min_m = std::min(v.rim_min_m, grid.heights_m[n]);
            v.rim_max_m = std::max(v.rim_max_m, grid.heights_m[n]);
          } else if (!seen[n]) {
            seen[n] = 1;
            component.push_back(n);
          }
        }
    }
    v.cells = static_cast<int>(component.size());
    v.margin_m = std::isfinite(v.rim_max_m - v.rim_min_m) ? v.rim_max_m - v.rim_min_m : 0.0;
    v.x_min = v.y_min = std::numeric_limits<double>::infinity();
    v.x_max = v.y_max = -std::numeric_limits<double>::infinity();
    for (const std::size_t k : component) {
      grid.heights_m[k] += v.margin_m;
      const double x = grid.x_of_col(static_cast<double>(k % grid.cols));
      const double y = grid.y_of_row(static_cast<double>(k / grid.cols));
      v.x_min = std::min(v.x_min, x);
      v.x_max = std::max(v.x_max, x);
      v.y_min = std::min(v.y_min, y);
      v.y_max = std::max(v.y_max, y);
    }
    regions.push_back(v);
  }
  return regions;
}

void check_writable_grid(const world::RasterGrid& grid, const std::filesystem::path& path) {
  validate_raster_grid(grid, path.string());
}

// GDAL geotransform of a grid: top-left CORNER and north-up pixel sizes.
std::array<double, 6> geotransform_of(const world::RasterGrid& grid) {
  return {grid.origin_x_m - 0.5 * grid.cell_x_m,
          grid.cell_x_m,
          0.0,
          grid.origin_y_m + (grid.rows - 0.5) * grid.cell_y_m,
          0.0,
          -grid.cell_y_m};
}

// Heights in GDAL's order: row 0 north.
std::vector<double> north_up_rows(const world::RasterGrid& grid) {
  std::vector<double> out(grid.heights_m.size());
  for (int r = 0; r < grid.rows; ++r) {
    std::copy_n(grid.heights_m.begin() + static_cast<std::ptrdiff_t>(r) * grid.cols, grid.cols,
                out.begin() + static_cast<std::ptrdiff_t>(grid.rows - 1 - r) * grid.cols);
  }
  return out;
}

void write_band(GDALDataset& ds, const world::RasterGrid& grid, const std::filesystem::path& path) {
  std::array<double, 6> gt = geotransform_of(grid);
  std::vector<double> rows = north_up_rows(grid);
  if (ds.SetGeoTransform(gt.data()) != CE_None ||
      ds.GetRasterBand(1)->RasterIO(GF_Write, 0, 0, grid.cols, grid.rows, rows.data(), grid.cols,
                                    grid.rows, GDT_Float64, 0, 0, nullptr) != CE_None) {
    throw InputError(path.string(), "cannot write the DEM: " + last_gdal_error());
  }
}

}  // namespace

DemRaster read_dem(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(name, "DEM file not found");
  if (std::filesystem::is_directory(path, ec))
    throw InputError(name, "is a directory, not a DEM file");
  register_gdal();
  QuietGdalErrors quiet;
  // ESRI ASCII grids with decimals are Float32 by default; keep their full precision.
  ScopedConfigOption ascii_precision("AAIGRID_DATATYPE", "Float64");
  DatasetPtr ds(GDALDataset::Open(name.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  if (!ds) throw InputError(name, "GDAL cannot read it as a raster: " + last_gdal_error());
  if (ds->GetRasterCount() < 1) throw InputError(name, "has no raster band");

  DemRaster dem;
  dem.path = name;
  if (GDALDriver* driver = ds->GetDriver()) dem.driver = driver->GetDescription();

  std::array<double, 6> gt{};
  if (ds->GetGeoTransform(gt.data()) != CE_None) {
    throw InputError(name, "has no georeferencing (geotransform); cannot place it");
  }
  if (gt[2] != 0.0 || gt[4] != 0.0) {
    throw InputError(name, fmt::format("rotated or sheared geotransform (terms {}, {}) is not "
                                       "supported; only north-up DEMs are (warp it with gdalwarp)",
                                       gt[2], gt[4]));
  }
  if (!(gt[1] > 0.0) || !(gt[5] < 0.0)) {
    throw InputError(name, fmt::format("pixel size ({}, {}) is not north-up (needs x > 0, y < 0)",
                                       gt[1], gt[5]));
  }

  world::RasterGrid& grid = dem.grid;
  grid.cols = ds->GetRasterXSize();
  grid.rows = ds->GetRasterYSize();
  grid.cell_x_m = gt[1];
  grid.cell_y_m = -gt[5];
  grid.origin_x_m = gt[0] + 0.5 * gt[1];
  grid.origin_y_m = gt[3] + (grid.rows - 0.5) * gt[5];

  GDALRasterBand* band = ds->GetRasterBand(1);
  const double unit_m = height_unit_m(band->GetUnitType());
  if (unit_m < 0.0) {
    throw InputError(name,
                     fmt::format("height unit '{}' is not metres or feet", band->GetUnitType()));
  }
  int has_scale = 0, has_offset = 0;
  const double scale = band->GetScale(&has_scale);
  const double offset = band->GetOffset(&has_offset);
  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  dem.has_nodata = has_nodata != 0;
  dem.nodata_value = nodata;

  const std::size_t count =
      static_cast<std::size_t>(grid.rows) * static_cast<std::size_t>(grid.cols);
  std::vector<double> raw(count);
  if (band->RasterIO(GF_Read, 0, 0, grid.cols, grid.rows, raw.data(), grid.cols, grid.rows,
                     GDT_Float64, 0, 0, nullptr) != CE_None) {
    throw InputError(name, "cannot read the height band: " + last_gdal_error());
  }

  grid.heights_m.resize(count);
  std::vector<char> is_void(count, 0);
  std::size_t voids = 0;
  for (int r = 0; r < grid.rows; ++r) {
    // GDAL's row 0 is the north edge; ours is the south edge.
    const std::size_t src = static_cast<std::size_t>(grid.rows - 1 - r) * grid.cols;
    const std::size_t dst = static_cast<std::size_t>(r) * grid.cols;
    for (int c = 0; c < grid.cols; ++c) {
      const double v = raw[src + c];
      const bool is_nodata =
          dem.has_nodata && (v == nodata || (std::isnan(nodata) && std::isnan(v)));
      if (is_nodata || !std::isfinite(v)) {
        is_void[dst + c] = 1;
        ++voids;
        grid.heights_m[dst + c] = 0.0;
      } else {
        grid.heights_m[dst + c] =
            (v * (has_scale ? scale : 1.0) + (has_offset ? offset : 0.0)) * unit_m;
      }
    }
  }
  if (2 * voids > count) {
    throw InputError(name, fmt::format("{} of {} cells are void (nodata); more than half is not "
                                       "a usable DEM",
                                       voids, count));
  }
  if (voids > 0) {
    dem.void_mask = is_void;
    dem.voids_filled = fill_voids(grid, is_void);
    dem.void_regions = raise_filled_voids(grid, dem.void_mask);
  }

  const OGRSpatialReference* srs = ds->GetSpatialRef();
  if (srs != nullptr && !srs->IsEmpty()) {
    dem.has_crs = true;
    char* wkt = nullptr;
    if (srs->exportToWkt(&wkt) == OGRERR_NONE && wkt != nullptr) dem.crs_wkt = wkt;
    CPLFree(wkt);
    dem.is_geographic = srs->IsGeographic();
    if (srs->IsCompound() || srs->IsVertical()) {
      const char* datum = srs->GetAttrValue("VERT_DATUM");
      const char* name = srs->GetAttrValue("VERT_CS");
      dem.vertical_datum = datum != nullptr ? datum : (name != nullptr ? name : "");
    }
    if (!dem.is_geographic) dem.linear_unit_m = srs->GetLinearUnits();
  }
  validate_raster_grid(grid, name);
  return dem;
}

world::RasterGrid to_local_frame(const DemRaster& dem) {
  if (dem.is_geographic) {
    throw InputError(dem.path,
                     "DEM CRS is geographic (degrees); placing it in the local metre frame needs "
                     "a geodetic origin: give the scenario a top-level 'origin: {lat_deg, "
                     "lon_deg, alt_amsl_m}' (degrees are never read as metres)");
  }
  world::RasterGrid grid = dem.grid;
  if (!dem.has_crs) {
    // An unlabeled raster whose spacing is a tiny fraction of a unit and whose extent fits
    // inside lon/lat ranges is almost surely in degrees (SRTM3 is 1/1200°): refuse it.
    const double west = grid.origin_x_m - 0.5 * grid.cell_x_m;
    const double south = grid.origin_y_m - 0.5 * grid.cell_y_m;
    const double east = west + grid.cols * grid.cell_x_m;
    const double north = south + grid.rows * grid.cell_y_m;
    if (grid.cell_x_m < 0.002 && grid.cell_y_m < 0.002 && west >= -180.0 && east <= 180.0 &&
        south >= -90.0 && north <= 90.0) {
      throw InputError(dem.path,
                       fmt::format("DEM has no CRS and a cell size of {} x {} units inside lon/lat "
                                   "ranges: it looks like degrees, which need a geodetic origin; "
                                   "give the file a projected CRS in metres",
                                   grid.cell_x_m, grid.cell_y_m));
    }
  }
  if (!(dem.linear_unit_m > 0.0) || !std::isfinite(dem.linear_unit_m)) {
    throw InputError(dem.path,
                     fmt::format("CRS linear unit {} m is not usable", dem.linear_unit_m));
  }
  grid.cell_x_m *= dem.linear_unit_m;
  grid.cell_y_m *= dem.linear_unit_m;
  // Local (0, 0) is the south-west CORNER, so the south-west cell's centre is half a cell in.
  grid.origin_x_m = 0.5 * grid.cell_x_m;
  grid.origin_y_m = 0.5 * grid.cell_y_m;
  return grid;
}

namespace {

struct WarpOptionsDeleter {
  void operator()(GDALWarpOptions* options) const {
    if (options == nullptr) return;
    if (options->pTransformerArg != nullptr)
      GDALDestroyGenImgProjTransformer(options->pTransformerArg);
    GDALDestroyWarpOptions(options);
  }
};

// Removes border rows and columns that hold voids, the edge with the most voids first, until
// none is left on the border; returns the kept window [r0, r1] x [c0, c1] (row 0 south).
struct Window {
  int r0, r1, c0, c1;
};
Window trim_void_border(const world::RasterGrid& grid, const std::vector<char>& is_void) {
  Window w{0, grid.rows - 1, 0, grid.cols - 1};
  auto void_at = [&](int r, int c) {
    return is_void[static_cast<std::size_t>(r) * grid.cols + c] != 0;
  };
  while (w.r0 <= w.r1 && w.c0 <= w.c1) {
    int south = 0, north = 0, west = 0, east = 0;
    for (int c = w.c0; c <= w.c1; ++c) {
      south += void_at(w.r0, c);
      north += void_at(w.r1, c);
    }
    for (int r = w.r0; r <= w.r1; ++r) {
      west += void_at(r, w.c0);
      east += void_at(r, w.c1);
    }
    const int worst = std::max({south, north, west, east});
    if (worst == 0) break;
    if (worst == south) {
      ++w.r0;
    } else if (worst == north) {
      --w.r1;
    } else if (worst == west) {
      ++w.c0;
    } else {
      --w.c1;
    }
  }
  return w;
}

// The DEM's CRS and the local frame's, both in (east, north) order. Throws InputError naming
// the DEM when it has no CRS (it cannot be placed) or GDAL cannot read it back.
struct FrameCrs {
  OGRSpatialReference source;
  OGRSpatialReference local;
};

void load_frame_crs(const DemRaster& dem, const GeoFrame& frame, FrameCrs& crs) {
  if (!dem.has_crs) {
    throw InputError(dem.path,
                     "DEM has no CRS, so it cannot be placed relative to the geodetic origin; "
                     "give the file its CRS (e.g. gdal_edit.py -a_srs EPSG:NNNN, or a .prj "
                     "beside an ESRI grid)");
  }
  if (crs.source.importFromWkt(dem.crs_wkt.c_str()) != OGRERR_NONE)
    throw InputError(dem.path, "GDAL cannot re-read the DEM's CRS: " + last_gdal_error());
  if (crs.local.SetFromUserInput(frame.proj_definition().c_str()) != OGRERR_NONE)
    throw InputError("origin", "GDAL cannot build the local frame's CRS '" +
                                   frame.proj_definition() + "': " + last_gdal_error());
  // Geotransforms are (x = east/longitude, y = north/latitude) whatever the CRS's axis order.
  crs.source.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  crs.local.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
}

}  // namespace

world::RasterGrid warp_to_frame(const DemRaster& dem, const GeoFrame& frame,
                                const std::optional<LocalWindow>& window) {
  register_gdal();
  QuietGdalErrors quiet;
  FrameCrs crs;
  load_frame_crs(dem, frame, crs);
  OGRSpatialReference& source_srs = crs.source;
  OGRSpatialReference& local_srs = crs.local;

  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  if (mem == nullptr) throw InputError(dem.path, "GDAL lacks the MEM driver");
  const world::RasterGrid& in = dem.grid;
  // The source is the read raster (voids filled, heights in metres) in its own CRS.
  DatasetPtr source(mem->Create("", in.cols, in.rows, 1, GDT_Float64, nullptr));
  if (!source) throw InputError(dem.path, "cannot stage the DEM: " + last_gdal_error());
  write_band(*source, in, dem.path);
  source->SetSpatialRef(&source_srs);

  char* local_wkt = nullptr;
  local_srs.exportToWkt(&local_wkt);
  CPLStringList transformer_options;
  transformer_options.SetNameValue("DST_SRS", local_wkt != nullptr ? local_wkt : "");
  CPLFree(local_wkt);
  void* suggest = GDALCreateGenImgProjTransformer2(GDALDataset::ToHandle(source.get()), nullptr,
                                                   transformer_options.List());
  if (suggest == nullptr) {
    throw InputError(dem.path, "GDAL/PROJ cannot transform the DEM's CRS into the local frame: " +
                                   last_gdal_error());
  }
  std::array<double, 6> gt{};
  int cols = 0, rows = 0;
  const CPLErr suggested =
      GDALSuggestedWarpOutput(GDALDataset::ToHandle(source.get()), GDALGenImgProjTransform, suggest,
                              gt.data(), &cols, &rows);
  GDALDestroyGenImgProjTransformer(suggest);
  if (suggested != CE_None || cols < 1 || rows < 1) {
    throw InputError(dem.path,
                     "GDAL cannot place the DEM in the local frame (is the origin on the same "
                     "side of the globe?): " +
                         last_gdal_error());
  }
  if (window) {
    // Only the part of the DEM around the window is warped (a 1° SRTM1 tile is 13 million
    // cells; a mission area a few thousand): the window plus two cells, cut to the DEM's own
    // footprint, on the lattice of the whole warp's cells, so every height is the one the
    // whole warp would give.
    const double res_x = gt[1], res_y = -gt[5];
    const double full_east = gt[0] + cols * res_x, full_south = gt[3] - rows * res_y;
    const double west = std::max(
        gt[0], gt[0] + std::floor((window->x_min_m - 2.0 * res_x - gt[0]) / res_x) * res_x);
    const double north = std::min(
        gt[3], gt[3] - std::floor((gt[3] - window->y_max_m - 2.0 * res_y) / res_y) * res_y);
    const double east = std::min(full_east, window->x_max_m + 2.0 * res_x);
    const double south = std::max(full_south, window->y_min_m - 2.0 * res_y);
    if (!(east > west) || !(north > south)) {
      throw InputError(
          dem.path,
          fmt::format("the DEM does not reach the area x [{}, {}], y [{}, {}] "
                      "m of the local frame",
                      window->x_min_m, window->x_max_m, window->y_min_m, window->y_max_m));
    }
    gt[0] = west;
    gt[3] = north;
    cols = std::max(1, static_cast<int>(std::ceil((east - west) / res_x - 1e-9)));
    rows = std::max(1, static_cast<int>(std::ceil((north - south) / res_y - 1e-9)));
  }

  DatasetPtr target(mem->Create("", cols, rows, 1, GDT_Float64, nullptr));
  if (!target) throw InputError(dem.path, "cannot create the warped raster: " + last_gdal_error());
  target->SetGeoTransform(gt.data());
  target->SetSpatialRef(&local_srs);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  target->GetRasterBand(1)->SetNoDataValue(nan);

  std::unique_ptr<GDALWarpOptions, WarpOptionsDeleter> options(GDALCreateWarpOptions());
  options->hSrcDS = GDALDataset::ToHandle(source.get());
  options->hDstDS = GDALDataset::ToHandle(target.get());
  options->nBandCount = 1;
  options->panSrcBands = static_cast<int*>(CPLMalloc(sizeof(int)));
  options->panSrcBands[0] = 1;
  options->panDstBands = static_cast<int*>(CPLMalloc(sizeof(int)));
  options->panDstBands[0] = 1;
  options->eResampleAlg = GRA_Bilinear;
  options->eWorkingDataType = GDT_Float64;
  options->padfDstNoDataReal = static_cast<double*>(CPLMalloc(sizeof(double)));
  options->padfDstNoDataReal[0] = nan;
  options->papszWarpOptions = CSLSetNameValue(options->papszWarpOptions, "INIT_DEST", "NO_DATA");
  // Exact transformation of every pixel (no approximating interpolation of the transform).
  options->pTransformerArg = GDALCreateGenImgProjTransformer2(
      GDALDataset::ToHandle(source.get()), GDALDataset::ToHandle(target.get()), nullptr);
  options->pfnTransformer = GDALGenImgProjTransform;
  if (options->pTransformerArg == nullptr) {
    throw InputError(dem.path, "GDAL cannot set up the warp: " + last_gdal_error());
  }
  GDALWarpOperation warp;
  if (warp.Initialize(options.get()) != CE_None ||
      warp.ChunkAndWarpImage(0, 0, cols, rows) != CE_None) {
    throw InputError(dem.path, "warping the DEM into the local frame failed: " + last_gdal_error());
  }

  std::vector<double> raw(static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows));
  if (target->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, cols, rows, raw.data(), cols, rows,
                                         GDT_Float64, 0, 0, nullptr) != CE_None) {
    throw InputError(dem.path, "cannot read the warped raster: " + last_gdal_error());
  }
  world::RasterGrid full;
  full.rows = rows;
  full.cols = cols;
  full.heights_m.resize(raw.size());
  std::vector<char> is_void(raw.size(), 0);
  for (int r = 0; r < rows; ++r) {
    const std::size_t src = static_cast<std::size_t>(rows - 1 - r) * cols;
    const std::size_t dst = static_cast<std::size_t>(r) * cols;
    for (int c = 0; c < cols; ++c) {
      full.heights_m[dst + c] = raw[src + c];
      is_void[dst + c] = std::isfinite(raw[src + c]) ? 0 : 1;
    }
  }
  const Window w = trim_void_border(full, is_void);
  if (w.r0 > w.r1 || w.c0 > w.c1) {
    throw InputError(dem.path, "no part of the DEM is left after warping it into the local frame");
  }
  world::RasterGrid grid;
  grid.rows = w.r1 - w.r0 + 1;
  grid.cols = w.c1 - w.c0 + 1;
  grid.cell_x_m = gt[1];
  grid.cell_y_m = -gt[5];
  grid.origin_x_m = gt[0] + (w.c0 + 0.5) * gt[1];
  grid.origin_y_m = gt[3] + (rows - 1 - w.r0 + 0.5) * gt[5];
  grid.heights_m.resize(static_cast<std::size_t>(grid.rows) * grid.cols);
  std::vector<char> inner_void(grid.heights_m.size(), 0);
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const std::size_t k = static_cast<std::size_t>(r + w.r0) * cols + (c + w.c0);
      grid.at(r, c) = is_void[k] ? 0.0 : full.heights_m[k];
      inner_void[static_cast<std::size_t>(r) * grid.cols + c] = is_void[k];
    }
  }
  // Voids inside the kept window (a source footprint with holes) fill from their rim.
  fill_voids(grid, inner_void);
  validate_raster_grid(grid, dem.path);
  return grid;
}

MappedDem map_to_frame(const DemRaster& dem, const GeoFrame& frame, const LocalWindow& window) {
  register_gdal();
  QuietGdalErrors quiet;
  FrameCrs crs;
  load_frame_crs(dem, frame, crs);
  OGRSpatialReference& source_srs = crs.source;
  OGRSpatialReference& local_srs = crs.local;
  std::unique_ptr<OGRCoordinateTransformation> to_source(
      OGRCreateCoordinateTransformation(&local_srs, &source_srs));
  if (!to_source)
    throw InputError(dem.path, "GDAL/PROJ cannot transform the local frame into the DEM's CRS: " +
                                   last_gdal_error());
  auto transform = [&](std::vector<double>& xs, std::vector<double>& ys) {
    std::vector<int> ok(xs.size(), 0);
    if (!to_source->Transform(xs.size(), xs.data(), ys.data(), nullptr, ok.data()) ||
        std::find(ok.begin(), ok.end(), 0) != ok.end())
      throw InputError(dem.path,
                       "PROJ cannot carry the area into the DEM's CRS (is the origin on the same "
                       "side of the globe?): " +
                           last_gdal_error());
  };

  const world::RasterGrid& in = dem.grid;
  // The DEM's cell in metres, roughly (only to size the margin).
  const double cell_m = dem.is_geographic ? std::max(in.cell_x_m, in.cell_y_m) * 111320.0
                                          : std::max(in.cell_x_m, in.cell_y_m) * dem.linear_unit_m;
  world::CoordinateMap map;
  constexpr double kLatticeSpacingM = 50.0;
  // Wide enough that a plan or a flight bulging out of the area (a turn, a detour) still
  // meets the DEM's own heights, not a clamped border.
  const double margin = 500.0 + 2.0 * cell_m;
  const double x0 = window.x_min_m - margin, x1 = window.x_max_m + margin;
  const double y0 = window.y_min_m - margin, y1 = window.y_max_m + margin;
  map.nx = std::max(2, static_cast<int>(std::ceil((x1 - x0) / kLatticeSpacingM)) + 1);
  map.ny = std::max(2, static_cast<int>(std::ceil((y1 - y0) / kLatticeSpacingM)) + 1);
  map.x0_m = x0;
  map.y0_m = y0;
  map.dx_m = (x1 - x0) / (map.nx - 1);
  map.dy_m = (y1 - y0) / (map.ny - 1);
  std::vector<double> xs, ys;
  for (int j = 0; j < map.ny; ++j)
    for (int i = 0; i < map.nx; ++i) {
      xs.push_back(x0 + i * map.dx_m);
      ys.push_back(y0 + j * map.dy_m);
    }
  transform(xs, ys);
  for (std::size_t k = 0; k < xs.size(); ++k) map.source.emplace_back(xs[k], ys[k]);
  world::validate_coordinate_map(map, dem.path);

  // The interpolation's error, where it is largest: the lattice cells' centres.
  xs.clear();
  ys.clear();
  for (int j = 0; j + 1 < map.ny; ++j)
    for (int i = 0; i + 1 < map.nx; ++i) {
      xs.push_back(x0 + (i + 0.5) * map.dx_m);
      ys.push_back(y0 + (j + 0.5) * map.dy_m);
    }
  std::vector<double> ex = xs, ey = ys;
  transform(ex, ey);
  Vec2 map_error = Vec2::Zero();
  for (std::size_t k = 0; k < xs.size(); ++k) {
    const Vec2 d = (map.at(xs[k], ys[k]) - Vec2(ex[k], ey[k])).cwiseAbs();
    map_error = map_error.cwiseMax(d);
  }

  // The area must lie on the DEM's cells: its border, every 25 m, mapped inside them.
  std::vector<Vec2> border;
  const double width = window.x_max_m - window.x_min_m, depth = window.y_max_m - window.y_min_m;
  const int nbx = std::max(2, static_cast<int>(std::ceil(width / 25.0)) + 1);
  const int nby = std::max(2, static_cast<int>(std::ceil(depth / 25.0)) + 1);
  for (int i = 0; i < nbx; ++i)
    for (const double y : {window.y_min_m, window.y_max_m})
      border.emplace_back(window.x_min_m + width * i / (nbx - 1), y);
  for (int j = 0; j < nby; ++j)
    for (const double x : {window.x_min_m, window.x_max_m})
      border.emplace_back(x, window.y_min_m + depth * j / (nby - 1));
  xs.clear();
  ys.clear();
  for (const Vec2& p : border) {
    xs.push_back(p.x());
    ys.push_back(p.y());
  }
  transform(xs, ys);
  const double west = in.origin_x_m - 0.5 * in.cell_x_m;
  const double south = in.origin_y_m - 0.5 * in.cell_y_m;
  const double east = in.x_of_col(in.cols - 1) + 0.5 * in.cell_x_m;
  const double north = in.y_of_row(in.rows - 1) + 0.5 * in.cell_y_m;
  const double tol =
      1e-9 * std::max({1.0, std::abs(west), std::abs(east), std::abs(south), std::abs(north)});
  Vec2 area_min(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
  Vec2 area_max = -area_min;
  for (std::size_t k = 0; k < xs.size(); ++k) {
    area_min = area_min.cwiseMin(Vec2(xs[k], ys[k]));
    area_max = area_max.cwiseMax(Vec2(xs[k], ys[k]));
    if (xs[k] < west - tol || xs[k] > east + tol || ys[k] < south - tol || ys[k] > north + tol)
      throw InputError(
          "area",
          fmt::format("x [{}, {}], y [{}, {}] m reaches beyond the DEM '{}': the local point "
                      "({:.1f}, {:.1f}) is at ({:.6f}, {:.6f}) in the DEM's CRS, outside its "
                      "cells [{:.6f}, {:.6f}] x [{:.6f}, {:.6f}]; terrain heights there would "
                      "be invented; shrink the area or use a larger DEM",
                      window.x_min_m, window.x_max_m, window.y_min_m, window.y_max_m, dem.path,
                      border[k].x(), border[k].y(), xs[k], ys[k], west, east, south, north));
  }

  // The cut: every cell the lattice reaches, plus two.
  Vec2 lo = map.source.front(), hi = map.source.front();
  for (const Vec2& p : map.source) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  auto col_of = [&](double x) { return (x - in.origin_x_m) / in.cell_x_m; };
  auto row_of = [&](double y) { return (y - in.origin_y_m) / in.cell_y_m; };
  MappedDem out;
  world::RasterGrid& cut = out.source;
  cut = world::crop(in, lo.x(), hi.x(), lo.y(), hi.y(), 2);

  const Vec2 slope = world::max_axis_slopes(cut);
  out.map_error_m = slope.x() * map_error.x() + slope.y() * map_error.y();
  out.map = std::move(map);

  // Voids: those reaching into the cut, and the share of the area's cells that were void.
  for (const VoidRegion& v : dem.void_regions)
    if (v.x_max >= cut.origin_x_m && v.x_min <= cut.x_of_col(cut.cols - 1) &&
        v.y_max >= cut.origin_y_m && v.y_min <= cut.y_of_row(cut.rows - 1))
      out.voids.push_back(v);
  const int ac0 = std::clamp(static_cast<int>(std::floor(col_of(area_min.x()))), 0, in.cols - 1);
  const int ac1 = std::clamp(static_cast<int>(std::ceil(col_of(area_max.x()))), 0, in.cols - 1);
  const int ar0 = std::clamp(static_cast<int>(std::floor(row_of(area_min.y()))), 0, in.rows - 1);
  const int ar1 = std::clamp(static_cast<int>(std::ceil(row_of(area_max.y()))), 0, in.rows - 1);
  for (int r = ar0; r <= ar1; ++r)
    for (int c = ac0; c <= ac1; ++c) {
      ++out.cells_in_area;
      if (!dem.void_mask.empty() && dem.void_mask[static_cast<std::size_t>(r) * in.cols + c])
        ++out.void_cells_in_area;
    }
  return out;
}

world::RasterGrid load_dem_in_frame(const std::filesystem::path& path, const GeoFrame& frame,
                                    const std::optional<LocalWindow>& window) {
  return warp_to_frame(read_dem(path), frame, window);
}

world::RasterGrid load_dem_local(const std::filesystem::path& path) {
  return to_local_frame(read_dem(path));
}

void write_dem_geotiff(const std::filesystem::path& path, const world::RasterGrid& grid, int epsg) {
  check_writable_grid(grid, path);
  register_gdal();
  QuietGdalErrors quiet;
  OGRSpatialReference srs;
  if (srs.importFromEPSG(epsg) != OGRERR_NONE) {
    throw InputError("epsg",
                     fmt::format("EPSG:{} is not a known CRS: {}", epsg, last_gdal_error()));
  }
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (driver == nullptr) throw InputError(path.string(), "GDAL has no GTiff driver");
  const std::string name = path.string();
  {
    DatasetPtr ds(driver->Create(name.c_str(), grid.cols, grid.rows, 1, GDT_Float64, nullptr));
    if (!ds) throw InputError(name, "cannot create the GeoTIFF: " + last_gdal_error());
    if (ds->SetSpatialRef(&srs) != CE_None) {
      throw InputError(name, "cannot set its CRS: " + last_gdal_error());
    }
    write_band(*ds, grid, path);
  }
  // GDAL flushes on close; a failure there is only visible in the error state.
  if (CPLGetLastErrorType() >= CE_Failure) {
    throw InputError(name, "writing the GeoTIFF failed: " + last_gdal_error());
  }
}

void write_dem_ascii_grid(const std::filesystem::path& path, const world::RasterGrid& grid) {
  check_writable_grid(grid, path);
  register_gdal();
  QuietGdalErrors quiet;
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDriver* aai = GetGDALDriverManager()->GetDriverByName("AAIGrid");
  if (mem == nullptr || aai == nullptr) {
    throw InputError(path.string(), "GDAL lacks the MEM or AAIGrid driver");
  }
  const std::string name = path.string();
  DatasetPtr staging(mem->Create("", grid.cols, grid.rows, 1, GDT_Float64, nullptr));
  if (!staging) throw InputError(name, "cannot stage the grid: " + last_gdal_error());
  write_band(*staging, grid, path);
  CPLStringList options;
  options.SetNameValue("SIGNIFICANT_DIGITS", "17");
  DatasetPtr out(
      aai->CreateCopy(name.c_str(), staging.get(), FALSE, options.List(), nullptr, nullptr));
  if (!out) throw InputError(name, "cannot write the ASCII grid: " + last_gdal_error());
  out.reset();
  if (CPLGetLastErrorType() >= CE_Failure) {
    throw InputError(name, "writing the ASCII grid failed: " + last_gdal_error());
  }
}

}  // namespace ridgeline::io
