#include "io/dem_file.hpp"

#include <gdal_priv.h>
#include <gtest/gtest.h>

#include "support/temp_dir.hpp"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"
#include "world/raster_grid.hpp"
#include "world/terrain.hpp"

namespace ridgeline::io {
namespace {

namespace fs = std::filesystem;

class DemFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing_support::fresh_test_dir();
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// A non-symmetric field (distinct values everywhere) in projected coordinates, so a row or
// column flip or an origin shift would show.
world::RasterGrid utm_grid() {
  world::PeakTerrainConfig config;
  config.base_elevation_m = 400.0;
  config.peaks = {{500'315.0, 5'200'410.0, 250.0, 150.0, 90.0}};
  world::PeakTerrain terrain(config);
  world::RasterGrid grid =
      world::sample_terrain(terrain, 30, 40, Vec2(500'015.0, 5'200'010.0), Vec2(30.0, 20.0));
  for (int r = 0; r < grid.rows; ++r) grid.at(r, 0) += 0.001 * r;  // a ramp on the west edge
  return grid;
}

void expect_same_heights(const world::RasterGrid& a, const world::RasterGrid& b, double tol) {
  ASSERT_EQ(a.rows, b.rows);
  ASSERT_EQ(a.cols, b.cols);
  for (int r = 0; r < a.rows; ++r) {
    for (int c = 0; c < a.cols; ++c) ASSERT_NEAR(a.at(r, c), b.at(r, c), tol) << r << ", " << c;
  }
}

TEST_F(DemFileTest, GeoTiffRoundTripKeepsHeightsGeometryAndCrs) {
  const world::RasterGrid grid = utm_grid();
  const fs::path file = dir_ / "dem.tif";
  write_dem_geotiff(file, grid, 32632);  // WGS 84 / UTM zone 32N
  const DemRaster dem = read_dem(file);
  EXPECT_EQ(dem.driver, "GTiff");
  EXPECT_TRUE(dem.has_crs);
  EXPECT_FALSE(dem.is_geographic);
  EXPECT_NE(dem.crs_wkt.find("UTM zone 32N"), std::string::npos) << dem.crs_wkt;
  EXPECT_DOUBLE_EQ(dem.linear_unit_m, 1.0);
  EXPECT_EQ(dem.voids_filled, 0);
  // Float64 storage: exact.
  expect_same_heights(dem.grid, grid, 0.0);
  EXPECT_DOUBLE_EQ(dem.grid.origin_x_m, grid.origin_x_m);
  EXPECT_DOUBLE_EQ(dem.grid.origin_y_m, grid.origin_y_m);
  EXPECT_DOUBLE_EQ(dem.grid.cell_x_m, 30.0);
  EXPECT_DOUBLE_EQ(dem.grid.cell_y_m, 20.0);

  // Local frame: (0, 0) is the south-west corner, half a cell from the first centre.
  const world::RasterGrid local = load_dem_local(file);
  EXPECT_DOUBLE_EQ(local.origin_x_m, 15.0);
  EXPECT_DOUBLE_EQ(local.origin_y_m, 10.0);
  expect_same_heights(local, grid, 0.0);
  // The peak at projected (500 315, 5 200 410) is at local (315, 410): the south-west corner
  // is (500 015 − 15, 5 200 010 − 10).
  const world::RasterTerrain terrain(local);
  world::PeakTerrainConfig config;
  config.base_elevation_m = 400.0;
  config.peaks = {{315.0, 410.0, 250.0, 150.0, 90.0}};
  const world::PeakTerrain expected(config);
  // The peak's centre is on a cell centre (col 10, row 20): exact there up to rounding.
  EXPECT_NEAR(terrain.height(315.0, 410.0), expected.height(315.0, 410.0), 1e-9);
  EXPECT_NEAR(terrain.height(315.0, 410.0), 650.0, 1e-9);
}

TEST_F(DemFileTest, AsciiGridRoundTripIsExact) {
  const world::RasterGrid grid = utm_grid();
  const fs::path file = dir_ / "dem.asc";
  write_dem_ascii_grid(file, grid);
  const DemRaster dem = read_dem(file);
  EXPECT_EQ(dem.driver, "AAIGrid");
  EXPECT_FALSE(dem.has_crs);
  // 17 significant digits represent every double exactly.
  expect_same_heights(dem.grid, grid, 0.0);
  EXPECT_DOUBLE_EQ(dem.grid.origin_x_m, grid.origin_x_m);
  EXPECT_DOUBLE_EQ(dem.grid.origin_y_m, grid.origin_y_m);
  EXPECT_DOUBLE_EQ(dem.grid.cell_x_m, grid.cell_x_m);
  EXPECT_DOUBLE_EQ(dem.grid.cell_y_m, grid.cell_y_m);
  // No CRS and metre-sized cells: accepted as metres.
  EXPECT_NO_THROW(load_dem_local(file));
}

TEST_F(DemFileTest, AsciiGridWrittenByHandIsReadWithRowZeroSouth) {
  // An independent reference: the ESRI format written by hand. The first data line is the
  // NORTH row; xllcorner/yllcorner is the lower-left corner of the lower-left cell.
  const fs::path file = dir_ / "hand.asc";
  std::ofstream(file) << "ncols 3\nnrows 2\nxllcorner 100\nyllcorner 200\ncellsize 10\n"
                         "NODATA_value -9999\n"
                         "1 2 3\n"
                         "4 5 6.5\n";
  const DemRaster dem = read_dem(file);
  EXPECT_DOUBLE_EQ(dem.grid.origin_x_m, 105.0);
  EXPECT_DOUBLE_EQ(dem.grid.origin_y_m, 205.0);
  EXPECT_DOUBLE_EQ(dem.grid.at(0, 0), 4.0);  // south-west
  EXPECT_DOUBLE_EQ(dem.grid.at(0, 2), 6.5);  // south-east
  EXPECT_DOUBLE_EQ(dem.grid.at(1, 0), 1.0);  // north-west
  const world::RasterGrid local = load_dem_local(file);
  const world::RasterTerrain terrain(local);
  // Local (5, 5) is the south-west cell centre; (15, 10) is halfway to the north row above
  // the middle column: (5 + 2)/2.
  EXPECT_DOUBLE_EQ(terrain.height(5.0, 5.0), 4.0);
  EXPECT_DOUBLE_EQ(terrain.height(15.0, 10.0), 3.5);
}

TEST_F(DemFileTest, NodataVoidsAreFilledFromValidNeighbours) {
  const fs::path file = dir_ / "voids.asc";
  // One isolated void in the middle and a 2-cell void at the east edge.
  std::ofstream(file) << "ncols 4\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 10\n"
                         "NODATA_value -9999\n"
                         "10 20 30 -9999\n"
                         "40 -9999 60 -9999\n"
                         "70 80 90 100\n";
  const DemRaster dem = read_dem(file);
  EXPECT_EQ(dem.voids_filled, 3);
  // Each void is spread from its rim and then raised by the rim's height range (a void can
  // hide a peak; dem_file.hpp, VoidRegion). Two voids: the middle cell, and the 2-cell one at
  // the east edge.
  ASSERT_EQ(dem.void_regions.size(), 2u);
  // Middle void (row 1, col 1): mean of its 8 valid neighbours 10 20 30 40 60 70 80 90 = 50,
  // plus their range 90 − 10.
  EXPECT_DOUBLE_EQ(dem.grid.at(1, 1), 50.0 + 80.0);
  // The east void's rim: 30, 60, 90, 100 (range 70). Row 1, col 3: its valid neighbours are
  // 90, 100 (south), 60 (west) and 30 (north-west): mean 70. Every void has a valid
  // neighbour, so one pass fills all.
  EXPECT_DOUBLE_EQ(dem.grid.at(1, 3), 70.0 + 70.0);
  // North-east corner (row 2, col 3): valid neighbours 30 (west) and 60 (south-west): 45.
  EXPECT_DOUBLE_EQ(dem.grid.at(2, 3), 45.0 + 70.0);
  for (const VoidRegion& v : dem.void_regions)
    EXPECT_DOUBLE_EQ(v.margin_m, v.cells == 1 ? 80.0 : 70.0);
}

TEST_F(DemFileTest, MostlyVoidDemIsRejected) {
  const fs::path file = dir_ / "empty.asc";
  std::ofstream(file) << "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 10\n"
                         "NODATA_value -9999\n-9999 -9999\n-9999 5\n";
  try {
    read_dem(file);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), file.string());
    EXPECT_NE(e.reason().find("3 of 4 cells are void"), std::string::npos) << e.reason();
  }
}

TEST_F(DemFileTest, MissingAndUnreadableFilesNameTheFile) {
  const fs::path missing = dir_ / "no_such_dem.tif";
  try {
    read_dem(missing);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), missing.string());
    EXPECT_NE(std::string(e.what()).find("no_such_dem.tif"), std::string::npos);
  }
  const fs::path garbage = dir_ / "garbage.tif";
  std::ofstream(garbage) << "this is not a raster";
  try {
    load_dem_local(garbage);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), garbage.string());
  }
}

// Writes an SRTM3-like tile: 1201 × 1201 big-endian int16, rows north to south, named for its
// south-west corner; heights h(r, c) = r − 2c + 500 (r from the north) except one void.
void write_hgt(const fs::path& file) {
  std::ofstream out(file, std::ios::binary);
  for (int r = 0; r < 1201; ++r) {
    for (int c = 0; c < 1201; ++c) {
      std::int16_t h = static_cast<std::int16_t>(r - 2 * c + 500 + 2000);
      if (r == 600 && c == 600) h = -32768;  // SRTM void
      const auto u = static_cast<std::uint16_t>(h);
      const char bytes[2] = {static_cast<char>(u >> 8), static_cast<char>(u & 0xFF)};
      out.write(bytes, 2);
    }
  }
}

TEST_F(DemFileTest, SrtmHgtIsReadAsGeographicWithCorrectValues) {
  const fs::path file = dir_ / "N46E008.hgt";
  write_hgt(file);
  const DemRaster dem = read_dem(file);
  EXPECT_EQ(dem.driver, "SRTMHGT");
  EXPECT_TRUE(dem.is_geographic);
  EXPECT_EQ(dem.grid.rows, 1201);
  EXPECT_EQ(dem.grid.cols, 1201);
  // SRTM samples are points on whole-degree lines: the south-west sample is at (8°E, 46°N),
  // spacing 3″ = 1/1200°.
  EXPECT_NEAR(dem.grid.origin_x_m, 8.0, 1e-9);
  EXPECT_NEAR(dem.grid.origin_y_m, 46.0, 1e-9);
  EXPECT_NEAR(dem.grid.cell_x_m, 1.0 / 1200.0, 1e-12);
  // Our row 0 is the file's last (southern) row r = 1200.
  const auto expected = [](int row, int col) { return (1200 - row) - 2 * col + 2500.0; };
  EXPECT_DOUBLE_EQ(dem.grid.at(0, 0), expected(0, 0));
  EXPECT_DOUBLE_EQ(dem.grid.at(1200, 1200), expected(1200, 1200));
  EXPECT_DOUBLE_EQ(dem.grid.at(17, 911), expected(17, 911));
  // The void is filled with the mean of a plane's 8 neighbours, the plane's own value, raised
  // by their height range (2 rows + 2·2 columns = 6 m).
  EXPECT_EQ(dem.voids_filled, 1);
  EXPECT_DOUBLE_EQ(dem.grid.at(600, 600), expected(600, 600) + 6.0);
}

TEST_F(DemFileTest, GeographicDemIsRejectedByTheLocalFrameLoader) {
  const fs::path hgt = dir_ / "N46E008.hgt";
  write_hgt(hgt);
  try {
    load_dem_local(hgt);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), hgt.string());
    EXPECT_NE(e.reason().find("geodetic origin"), std::string::npos) << e.reason();
  }
  // A GeoTIFF in EPSG:4326 likewise.
  world::RasterGrid grid;
  grid.rows = 3;
  grid.cols = 3;
  grid.origin_x_m = 8.5;
  grid.origin_y_m = 46.5;
  grid.cell_x_m = grid.cell_y_m = 1.0 / 1200.0;
  grid.heights_m.assign(9, 1000.0);
  const fs::path tif = dir_ / "wgs84.tif";
  write_dem_geotiff(tif, grid, 4326);
  EXPECT_TRUE(read_dem(tif).is_geographic);
  EXPECT_THROW(load_dem_local(tif), InputError);
  // And degrees without a CRS label (an ASCII grid has no .prj).
  const fs::path asc = dir_ / "degrees.asc";
  write_dem_ascii_grid(asc, grid);
  EXPECT_FALSE(read_dem(asc).has_crs);
  EXPECT_THROW(load_dem_local(asc), InputError);
}

TEST_F(DemFileTest, RotatedGeotransformIsRejected) {
  // GDAL itself writes a GeoTIFF with rotation terms (our writer only writes north-up).
  GDALAllRegister();
  const fs::path file = dir_ / "rotated.tif";
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  {
    GDALDataset* ds = driver->Create(file.string().c_str(), 4, 3, 1, GDT_Float64, nullptr);
    ASSERT_NE(ds, nullptr);
    double gt[6] = {500000.0, 30.0, 5.0, 5200600.0, 5.0, -20.0};
    ds->SetGeoTransform(gt);
    std::vector<double> heights(12, 100.0);
    ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, 4, 3, heights.data(), 4, 3,
                                             GDT_Float64, 0, 0, nullptr),
              CE_None);
    GDALClose(GDALDataset::ToHandle(ds));
  }
  try {
    read_dem(file);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), file.string());
    EXPECT_NE(e.reason().find("north-up"), std::string::npos) << e.reason();
  }
}

TEST_F(DemFileTest, InvalidEpsgIsRejected) {
  EXPECT_THROW(write_dem_geotiff(dir_ / "x.tif", utm_grid(), 999999), InputError);
}

}  // namespace
}  // namespace ridgeline::io
