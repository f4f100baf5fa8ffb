// Issue 18: the terrain's vertical datum is stated. A DEM whose CRS names one (a compound CRS)
// is reported with it, and a scenario that says otherwise is one error naming
// terrain.dem.vertical_datum; a scenario's own statement is reported as such; with neither, the
// run says what it assumed.
#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.hpp"
#include "io/dem_file.hpp"
#include "io/scenario_file.hpp"
#include "io/scenario_summary.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline::io {
namespace {

namespace fs = std::filesystem;

world::RasterGrid slope() {
  world::RasterGrid g;
  g.rows = g.cols = 30;
  g.cell_x_m = g.cell_y_m = 30.0;
  g.origin_x_m = 500015.0;
  g.origin_y_m = 4100015.0;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) g.heights_m.push_back(1000.0 + 2.0 * c + r);
  return g;
}

std::string scenario(const std::string& dem, const std::string& datum_line) {
  return "name: datum\narea: {x_min_m: 100, x_max_m: 800, y_min_m: 100, y_max_m: 800}\n"
         "terrain: {dem: {path: " +
         dem + ", model: raster" + datum_line +
         "}}\n"
         "altitude: {min_m: 900, max_m: 2000}\n"
         "uavs:\n  - {name: a, start: {position_m: [200, 200, 1200], heading_deg: 45}}\n"
         "targets:\n  - {name: t, position_m: [700, 700, 1200]}\n";
}

std::string vertical_datum_line(const fs::path& yaml) {
  const LoadedScenario loaded = load_scenario_file(yaml);
  const std::string text = summary_text(summarize(loaded));
  const auto at = text.find("vertical datum: ");
  return at == std::string::npos ? "" : text.substr(at, text.find('\n', at) - at);
}

TEST(DemVerticalDatum, ItsSourceIsStatedAndAContradictionIsAnError) {
  const fs::path dir = testing_support::fresh_test_dir();
  write_dem_geotiff(dir / "plain.tif", slope(), 32612);
  write_dem_geotiff(dir / "egm96.tif", slope(), 32612);
  {  // UTM 12N + EGM96 height (EPSG:5773): a compound CRS with a vertical datum.
    GDALAllRegister();
    GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen((dir / "egm96.tif").c_str(), GA_Update));
    ASSERT_NE(ds, nullptr);
    OGRSpatialReference srs;
    ASSERT_EQ(srs.SetFromUserInput("EPSG:32612+5773"), OGRERR_NONE);
    ASSERT_EQ(ds->SetSpatialRef(&srs), CE_None);
    GDALClose(ds);
  }
  EXPECT_NE(read_dem(dir / "egm96.tif").vertical_datum.find("EGM96"), std::string::npos);
  EXPECT_TRUE(read_dem(dir / "plain.tif").vertical_datum.empty());

  std::ofstream(dir / "a.yaml") << scenario("plain.tif", "");
  EXPECT_NE(vertical_datum_line(dir / "a.yaml").find("not stated"), std::string::npos)
      << vertical_datum_line(dir / "a.yaml");
  std::ofstream(dir / "b.yaml") << scenario("plain.tif", ", vertical_datum: NAVD88");
  EXPECT_EQ(vertical_datum_line(dir / "b.yaml"), "vertical datum: NAVD88 (stated in the scenario)");
  std::ofstream(dir / "c.yaml") << scenario("egm96.tif", "");
  EXPECT_NE(vertical_datum_line(dir / "c.yaml").find("EGM96"), std::string::npos);
  EXPECT_NE(vertical_datum_line(dir / "c.yaml").find("from the DEM's CRS"), std::string::npos);
  std::ofstream(dir / "d.yaml") << scenario("egm96.tif", ", vertical_datum: egm96");
  EXPECT_NO_THROW(load_scenario_file(dir / "d.yaml"));
  // A part of a name is not the name: "EGM" could be EGM2008.
  std::ofstream(dir / "f.yaml") << scenario("egm96.tif", ", vertical_datum: EGM");
  EXPECT_THROW(load_scenario_file(dir / "f.yaml"), InputError);
  std::ofstream(dir / "e.yaml") << scenario("egm96.tif", ", vertical_datum: NAVD88");
  try {
    load_scenario_file(dir / "e.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.dem.vertical_datum");
    EXPECT_NE(e.reason().find("EGM96"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ridgeline::io
