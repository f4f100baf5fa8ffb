// DEMs in other CRSs warped into a geodetic origin's local frame (io/dem_file.hpp,
// load_dem_in_frame). The reference is an analytic terrain written as a function of latitude
// and longitude, evaluated at each local point through the frame's inverse projection: no
// raster code is shared with it. The UTM copy is made here with GDAL's own gdalwarp utility.
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"
#include "io/dem_file.hpp"
#include "io/geo_frame.hpp"
#include "support/temp_dir.hpp"
#include "world/raster_grid.hpp"
#include "world/terrain.hpp"

namespace ridgeline::io {
namespace {

namespace fs = std::filesystem;

// A valley floor at 800 m AMSL with a 250 m hill and a ridge, as a function of lat/lon.
constexpr double kOriginLat = 46.52, kOriginLon = 7.96;  // UTM zone 32: 1° west of its meridian
double analytic_height(double lat_deg, double lon_deg) {
  const double u = (lat_deg - 46.525) / 0.004, v = (lon_deg - 7.955) / 0.006;
  const double ridge = (lat_deg - 46.505) / 0.003;
  return 800.0 + 250.0 * std::exp(-0.5 * (u * u + v * v)) +
         120.0 * std::exp(-0.5 * ridge * ridge) * (1.0 + 0.3 * std::sin(lon_deg * 300.0));
}

// An EPSG:4326 grid of 1 arc-second cells (~31 m north, ~21 m east) covering lat
// [46.49, 46.55] x lon [7.92, 8.00].
world::RasterGrid geographic_grid() {
  world::RasterGrid g;
  g.cell_x_m = 1.0 / 3600.0;  // degrees, despite the name (see DemRaster)
  g.cell_y_m = 1.0 / 3600.0;
  g.cols = 288;
  g.rows = 216;
  g.origin_x_m = 7.92 + 0.5 * g.cell_x_m;
  g.origin_y_m = 46.49 + 0.5 * g.cell_y_m;
  g.heights_m.resize(static_cast<std::size_t>(g.rows) * g.cols);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) g.at(r, c) = analytic_height(g.y_of_row(r), g.x_of_col(c));
  return g;
}

void gdal_warp(const fs::path& in, const fs::path& out, const std::vector<std::string>& args) {
  GDALAllRegister();
  CPLStringList argv;
  for (const std::string& a : args) argv.AddString(a.c_str());
  GDALWarpAppOptions* options = GDALWarpAppOptionsNew(argv.List(), nullptr);
  ASSERT_NE(options, nullptr);
  GDALDatasetH src = GDALOpen(in.c_str(), GA_ReadOnly);
  ASSERT_NE(src, nullptr);
  int usage_error = 0;
  GDALDatasetH dst = GDALWarp(out.c_str(), nullptr, 1, &src, options, &usage_error);
  GDALWarpAppOptionsFree(options);
  ASSERT_NE(dst, nullptr);
  GDALClose(dst);
  GDALClose(src);
}

bool inside(const world::RasterGrid& g, double x, double y) {
  return x >= g.origin_x_m && x <= g.x_of_col(g.cols - 1) && y >= g.origin_y_m &&
         y <= g.y_of_row(g.rows - 1);
}

class DemWarp : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = testing_support::fresh_test_dir(); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(DemWarp, GeographicAndUtmCopiesOfOneTerrainAgreeInTheLocalFrame) {
  const fs::path geo_tif = dir_ / "geo.tif", utm_tif = dir_ / "utm.tif";
  write_dem_geotiff(geo_tif, geographic_grid(), 4326);
  gdal_warp(geo_tif, utm_tif, {"-t_srs", "EPSG:32632", "-tr", "25", "25", "-r", "cubic"});

  const GeoFrame frame({kOriginLat, kOriginLon, 800.0});
  const world::RasterTerrain from_geo(load_dem_in_frame(geo_tif, frame));
  const world::RasterTerrain from_utm(load_dem_in_frame(utm_tif, frame));
  // The local origin lies inside both, and both span kilometres around it.
  for (const world::RasterTerrain* t : {&from_geo, &from_utm}) {
    EXPECT_TRUE(inside(t->grid(), 0.0, 0.0));
    EXPECT_GT(t->grid().cols * t->grid().cell_x_m, 5000.0);
    EXPECT_GT(t->grid().rows * t->grid().cell_y_m, 5000.0);
  }

  Rng rng(4);
  int compared = 0;
  double worst_geo = 0.0, worst_utm = 0.0, worst_pair = 0.0;
  for (int k = 0; k < 4000; ++k) {
    const double x = rng.uniform(-2800.0, 2800.0), y = rng.uniform(-3000.0, 3000.0);
    if (!inside(from_geo.grid(), x, y) || !inside(from_utm.grid(), x, y)) continue;
    const GeoPoint p = frame.to_geodetic(Vec3(x, y, 0.0));
    const double truth = analytic_height(p.lat_deg, p.lon_deg);
    worst_geo = std::max(worst_geo, std::abs(from_geo.height(x, y) - truth));
    worst_utm = std::max(worst_utm, std::abs(from_utm.height(x, y) - truth));
    worst_pair = std::max(worst_pair, std::abs(from_geo.height(x, y) - from_utm.height(x, y)));
    ++compared;
  }
  EXPECT_GT(compared, 3000);
  // Bilinear interpolation errs by up to (Δx²|h_xx| + Δy²|h_yy|)/8: with curvatures up to
  // ~2e-3 /m (hill 250 m over σ ≈ 450 m, ridge, ripple) on 21 m x 31 m cells that is ~0.35 m,
  // and every height here is interpolated twice (the warp, then the terrain query on the
  // warped grid); the UTM copy is resampled a third time (cubic, by gdalwarp). Measured:
  // 0.55 m, 0.45 m and 0.64 m. A misplaced raster (swapped axes, a flipped row order, the
  // meridian convergence of 0.75° ignored: 40 m at 3 km) errs by tens of metres on these
  // slopes.
  EXPECT_LT(worst_geo, 1.0);
  EXPECT_LT(worst_utm, 1.2);
  EXPECT_LT(worst_pair, 1.5);
}

TEST_F(DemWarp, EsriGridWithPrjIsPlacedLikeTheGeoTiff) {
  const fs::path geo_tif = dir_ / "geo.tif", utm_tif = dir_ / "utm.tif";
  write_dem_geotiff(geo_tif, geographic_grid(), 4326);
  gdal_warp(geo_tif, utm_tif, {"-t_srs", "EPSG:32632", "-tr", "30", "30", "-r", "bilinear"});
  // The same raster as an ESRI ASCII grid whose CRS is only in the .prj beside it.
  DemRaster utm = read_dem(utm_tif);
  const fs::path asc = dir_ / "utm.asc";
  write_dem_ascii_grid(asc, utm.grid);
  OGRSpatialReference srs;
  ASSERT_EQ(srs.importFromEPSG(32632), OGRERR_NONE);
  ASSERT_EQ(srs.morphToESRI(), OGRERR_NONE);
  char* wkt = nullptr;
  ASSERT_EQ(srs.exportToWkt(&wkt), OGRERR_NONE);
  std::ofstream(dir_ / "utm.prj") << wkt;
  CPLFree(wkt);

  const GeoFrame frame({kOriginLat, kOriginLon, 800.0});
  const world::RasterGrid a = load_dem_in_frame(utm_tif, frame);
  const world::RasterGrid b = load_dem_in_frame(asc, frame);
  ASSERT_EQ(a.rows, b.rows);
  ASSERT_EQ(a.cols, b.cols);
  EXPECT_NEAR(a.origin_x_m, b.origin_x_m, 1e-6);
  EXPECT_NEAR(a.origin_y_m, b.origin_y_m, 1e-6);
  for (std::size_t i = 0; i < a.heights_m.size(); ++i)
    ASSERT_NEAR(a.heights_m[i], b.heights_m[i], 1e-6) << i;
}

TEST_F(DemWarp, TheWarpedGridHasNoVoidsAndKeepsRealElevations) {
  const fs::path geo_tif = dir_ / "geo.tif";
  const world::RasterGrid source = geographic_grid();
  write_dem_geotiff(geo_tif, source, 4326);
  const world::RasterGrid local =
      load_dem_in_frame(geo_tif, GeoFrame({kOriginLat, kOriginLon, 0.0}));
  double lo = 1e9, hi = -1e9;
  for (double h : local.heights_m) {
    ASSERT_TRUE(std::isfinite(h));
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  double src_lo = 1e9, src_hi = -1e9;
  for (double h : source.heights_m) {
    src_lo = std::min(src_lo, h);
    src_hi = std::max(src_hi, h);
  }
  // Interpolation never leaves the source's range, and the border trim keeps nearly all of it.
  EXPECT_GE(lo, src_lo - 1e-9);
  EXPECT_LE(hi, src_hi + 1e-9);
  EXPECT_GT(hi - lo, 0.9 * (src_hi - src_lo));
  EXPECT_GT(lo, 799.0);
}

// A broad hill on an SRTM3 tile N46E007 (1201 x 1201 big-endian int16, rows from the north,
// samples on whole 3-arc-second lines), as a function of latitude and longitude.
double srtm_hill(double lat_deg, double lon_deg) {
  const double u = (lat_deg - 46.52) / 0.05, v = (lon_deg - 7.47) / 0.07;
  return 800.0 + 1200.0 * std::exp(-0.5 * (u * u + v * v));
}

TEST_F(DemWarp, SrtmHgtTileWithAVoidIsWarpedAroundAnOrigin) {
  const fs::path hgt = dir_ / "N46E007.hgt";
  {
    std::ofstream out(hgt, std::ios::binary);
    for (int r = 0; r < 1201; ++r) {
      for (int c = 0; c < 1201; ++c) {
        auto h =
            static_cast<std::int16_t>(std::lround(srtm_hill(47.0 - r / 1200.0, 7.0 + c / 1200.0)));
        if (r == 576 && c == 600) h = -32768;  // an SRTM void near the origin
        const auto word = static_cast<std::uint16_t>(h);
        const char bytes[2] = {static_cast<char>(word >> 8), static_cast<char>(word & 0xFF)};
        out.write(bytes, 2);
      }
    }
  }
  const GeoFrame frame({46.5, 7.5, 800.0});
  const world::RasterTerrain terrain(load_dem_in_frame(hgt, frame));
  // The tile spans 111 km x 77 km around the origin.
  EXPECT_LT(terrain.grid().origin_x_m, -35e3);
  EXPECT_GT(terrain.grid().x_of_col(terrain.grid().cols - 1), 35e3);
  Rng rng(11);
  double worst = 0.0;
  for (int k = 0; k < 3000; ++k) {
    const double x = rng.uniform(-20e3, 20e3), y = rng.uniform(-20e3, 20e3);
    const GeoPoint g = frame.to_geodetic(Vec3(x, y, 0.0));
    worst = std::max(worst, std::abs(terrain.height(x, y) - srtm_hill(g.lat_deg, g.lon_deg)));
  }
  // Rounding to whole metres (0.5 m) plus two bilinear interpolations of a hill with
  // |h''| <= 1200 m / (3.8 km)² on ~93 m x 64 m cells (~0.2 m each). Measured: 0.76 m.
  EXPECT_LT(worst, 1.5);
  // Warping only a 4 km window of the tile gives a small grid with the same heights.
  const world::RasterTerrain part(
      load_dem_in_frame(hgt, frame, LocalWindow{-2000.0, 2000.0, -1500.0, 2500.0}));
  const world::RasterGrid& pg = part.grid();
  EXPECT_LT(pg.cols * pg.cell_x_m, 4000.0 + 6.0 * pg.cell_x_m);
  EXPECT_LT(pg.rows * pg.cell_y_m, 4000.0 + 6.0 * pg.cell_y_m);
  EXPECT_LE(pg.origin_x_m, -2000.0 + 0.5 * pg.cell_x_m);
  EXPECT_GE(pg.x_of_col(pg.cols - 1), 2000.0 - 0.5 * pg.cell_x_m);
  EXPECT_LE(pg.origin_y_m, -1500.0 + 0.5 * pg.cell_y_m);
  EXPECT_GE(pg.y_of_row(pg.rows - 1), 2500.0 - 0.5 * pg.cell_y_m);
  for (int k = 0; k < 500; ++k) {
    const double x = rng.uniform(-2000.0, 2000.0), y = rng.uniform(-1500.0, 2500.0);
    const GeoPoint g = frame.to_geodetic(Vec3(x, y, 0.0));
    ASSERT_NEAR(part.height(x, y), srtm_hill(g.lat_deg, g.lon_deg), 1.5);
    // On the whole warp's cell lattice: the whole warp's heights, but for centimetres (GDAL's
    // warper sizes its bilinear kernel per output chunk from the chunk's source window, and the
    // chunks differ; measured 0.053 m at most here).
    ASSERT_NEAR(part.height(x, y), terrain.height(x, y), 0.15);
  }
  // The void (46.52°N, 7.5°E) is filled from its neighbours, not read as -32768 m, and
  // raised by their height range (a few metres on this hill): above the hill, never below.
  const Vec3 at_void = frame.to_local({46.52, 7.5, 0.0});
  EXPECT_GT(terrain.height(at_void.x(), at_void.y()), srtm_hill(46.52, 7.5) - 0.5);
  EXPECT_LT(terrain.height(at_void.x(), at_void.y()), srtm_hill(46.52, 7.5) + 10.0);
}

TEST_F(DemWarp, DegreesWithoutOriginAndNoCrsWithOriginAreErrors) {
  const fs::path geo_tif = dir_ / "geo.tif";
  write_dem_geotiff(geo_tif, geographic_grid(), 4326);
  try {
    (void)load_dem_local(geo_tif);
    FAIL() << "a DEM in degrees was read without an origin";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("geodetic origin"), std::string::npos) << e.what();
  }
  world::RasterGrid metres = geographic_grid();
  metres.cell_x_m = metres.cell_y_m = 30.0;
  metres.origin_x_m = metres.origin_y_m = 15.0;
  const fs::path bare = dir_ / "bare.asc";
  write_dem_ascii_grid(bare, metres);
  try {
    (void)load_dem_in_frame(bare, GeoFrame({kOriginLat, kOriginLon, 0.0}));
    FAIL() << "a DEM without a CRS was placed relative to a geodetic origin";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no CRS"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ridgeline::io
