// Issue 18: a DEM's voids (no-data cells) are filled, raised by their rim's height range (a
// void can hide a peak), and reported: read_dem lists each void with its extent and margin,
// the scenario's terrain report (what `validate` prints) says how many cells under the area
// were void, and a DEM whose voids cover more than kMaxVoidShareInArea of the area is one
// error naming terrain.dem.path.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "core/error.hpp"
#include "io/dem_file.hpp"
#include "io/scenario_file.hpp"
#include "io/scenario_summary.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline::io {
namespace {

namespace fs = std::filesystem;

constexpr int kCells = 40;
constexpr double kCellM = 30.0;

// An ESRI ASCII grid (no CRS: metres, local frame = the grid's own) of a slope, with no-data
// where `is_void(row from south, col)` holds.
void write_grid(const fs::path& path, const std::function<bool(int, int)>& is_void) {
  std::ofstream out(path);
  out << "ncols " << kCells << "\nnrows " << kCells << "\nxllcorner 0\nyllcorner 0\ncellsize "
      << kCellM << "\nNODATA_value -9999\n";
  for (int line = 0; line < kCells; ++line) {  // north row first
    const int row = kCells - 1 - line;
    for (int col = 0; col < kCells; ++col)
      out << (is_void(row, col) ? -9999.0 : 100.0 + 3.0 * col + 1.0 * row) << ' ';
    out << '\n';
  }
}

bool hole(int row, int col) { return row >= 10 && row <= 12 && col >= 20 && col <= 23; }

std::string scenario_yaml() {
  return R"(
name: voids
area: {x_min_m: 100, x_max_m: 1100, y_min_m: 100, y_max_m: 1100}
terrain: {dem: {path: dem.asc, model: raster}}
uavs:
  - {name: a, start: {position_m: [200, 200, 400], heading_deg: 45}}
targets:
  - {name: t, position_m: [900, 900, 400]}
)";
}

TEST(DemVoids, AVoidIsFilledAboveItsRimAndReportedWithItsMargin) {
  const fs::path dir = testing_support::fresh_test_dir();
  write_grid(dir / "dem.asc", hole);
  const DemRaster dem = read_dem(dir / "dem.asc");
  EXPECT_EQ(dem.voids_filled, 12);
  ASSERT_EQ(dem.void_regions.size(), 1u);
  const VoidRegion& v = dem.void_regions.front();
  EXPECT_EQ(v.cells, 12);
  // The rim: rows 9..13, cols 19..24 around the hole.
  const double rim_min = 100.0 + 3.0 * 19 + 9.0, rim_max = 100.0 + 3.0 * 24 + 13.0;
  EXPECT_DOUBLE_EQ(v.rim_min_m, rim_min);
  EXPECT_DOUBLE_EQ(v.rim_max_m, rim_max);
  EXPECT_DOUBLE_EQ(v.margin_m, rim_max - rim_min);
  EXPECT_DOUBLE_EQ(v.x_min, 20.5 * kCellM);  // cell centres, the grid's coordinates
  EXPECT_DOUBLE_EQ(v.x_max, 23.5 * kCellM);
  for (int r = 0; r < kCells; ++r)
    for (int c = 0; c < kCells; ++c) {
      const double h = dem.grid.at(r, c);
      if (hole(r, c))
        EXPECT_GE(h, rim_max) << r << ", " << c;  // never below what the rim allows
      else
        EXPECT_DOUBLE_EQ(h, 100.0 + 3.0 * c + r);  // valid cells untouched
    }

  std::ofstream(dir / "s.yaml") << scenario_yaml();
  const LoadedScenario loaded = load_scenario_file(dir / "s.yaml");
  EXPECT_EQ(loaded.terrain_report.void_cells_in_area, 12);
  EXPECT_GT(loaded.terrain_report.cells_in_area, 30 * 30);
  const std::string text = summary_text(summarize(loaded));
  EXPECT_NE(text.find("DEM voids filled: 12 of"), std::string::npos) << text;
  EXPECT_NE(text.find(fmt::format("margin {:.1f} m", rim_max - rim_min)), std::string::npos)
      << text;
  EXPECT_NE(text.find("error bound 0.0000 m"), std::string::npos) << text;
  fs::remove_all(dir);
}

TEST(DemVoids, TooManyVoidsUnderTheAreaIsOneErrorNamingTheDem) {
  const fs::path dir = testing_support::fresh_test_dir();
  // A 15-cell-wide void band through the middle: 15/34 of the area's cells.
  write_grid(dir / "dem.asc", [](int row, int) { return row >= 12 && row < 27; });
  std::ofstream(dir / "s.yaml") << scenario_yaml();
  try {
    load_scenario_file(dir / "s.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.dem.path");
    EXPECT_NE(e.reason().find("under the area are void"), std::string::npos) << e.what();
  }
  // The same DEM under an area clear of the band is usable.
  std::string yaml = scenario_yaml();
  yaml.replace(yaml.find("y_min_m: 100, y_max_m: 1100"), 27, "y_min_m: 850, y_max_m: 1150");
  yaml.replace(yaml.find("[200, 200, 400]"), 15, "[200, 900, 400]");
  yaml.replace(yaml.find("[900, 900, 400]"), 15, "[900, 1000, 400]");
  std::ofstream(dir / "s2.yaml") << yaml;
  EXPECT_NO_THROW(load_scenario_file(dir / "s2.yaml"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ridgeline::io
