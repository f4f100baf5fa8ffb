// Issue 18: on a DEM in degrees with a sharp ridge, the terrain clearance a run reports is
// what an independent re-check of its trajectories against the SOURCE DEM finds: each row of
// trajectories.csv is carried back to longitude/latitude by PROJ directly (not through the
// project's GeoFrame) and the height is the bilinear interpolation of the source pixels,
// written out here, not RasterTerrain's. Before, the DEM was warped onto a local grid and the
// warp cut the crest of a sharp ridge: the reported clearance was metres too optimistic.
#include <gtest/gtest.h>
#include <proj.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "io/dem_file.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kLat0 = 37.30, kLon0 = -113.00, kCell = 1.0 / 1200.0;  // SRTM3: 3 arc-seconds

int run_cli(const std::string& args, const fs::path& log) {
  const std::string cmd =
      std::string(RIDGELINE_CLI_PATH) + " " + args + " >" + log.string() + " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A knife-edge ridge 420 m high and 160 m wide at its foot, running 30° east of north through
// the origin, on a 1500 m plain: at 3" cells (about 74 m x 93 m here) its crest is one or two
// pixels wide, which is what a resampling warp cuts.
double ridge_height(double lat_deg, double lon_deg) {
  const double north_m = (lat_deg - kLat0) * 110950.0;
  const double east_m = (lon_deg - kLon0) * 88700.0;
  const double across = east_m * std::cos(M_PI / 6.0) - north_m * std::sin(M_PI / 6.0);
  return 1500.0 + 420.0 * std::max(0.0, 1.0 - std::abs(across) / 80.0);
}

world::RasterGrid ridge_dem() {
  world::RasterGrid g;
  g.cell_x_m = g.cell_y_m = kCell;
  g.cols = 120;
  g.rows = 100;
  g.origin_x_m = kLon0 - 60 * kCell + 0.5 * kCell;
  g.origin_y_m = kLat0 - 50 * kCell + 0.5 * kCell;
  g.heights_m.resize(static_cast<std::size_t>(g.rows) * g.cols);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) g.at(r, c) = ridge_height(g.y_of_row(r), g.x_of_col(c));
  return g;
}

// Bilinear interpolation of the source pixels at (lon, lat): pixel (c, r) has its centre at
// origin + (c, r)·cell, row 0 south.
double source_height(const world::RasterGrid& g, double lon, double lat) {
  const double u = (lon - g.origin_x_m) / g.cell_x_m, v = (lat - g.origin_y_m) / g.cell_y_m;
  const int c = std::clamp(static_cast<int>(std::floor(u)), 0, g.cols - 2);
  const int r = std::clamp(static_cast<int>(std::floor(v)), 0, g.rows - 2);
  const double a = u - c, b = v - r;
  return (1 - a) * (1 - b) * g.at(r, c) + a * (1 - b) * g.at(r, c + 1) +
         (1 - a) * b * g.at(r + 1, c) + a * b * g.at(r + 1, c + 1);
}

const char* kScenario = R"(
name: ridge
origin: {lat_deg: 37.30, lon_deg: -113.00, alt_amsl_m: 1500}
altitude: {min_m: 20, max_m: 700, reference: home}
safety: {terrain_clearance_m: 30}
area: {x_min_m: -1800, x_max_m: 1800, y_min_m: -1500, y_max_m: 1500}
terrain: {dem: {path: ridge.tif, model: raster}}
uavs:
  - {name: a, start: {position_m: [-1400, -900, 1560], heading_deg: 90}}
  - {name: b, start: {position_m: [-1400, 0, 1560], heading_deg: 90}}
  - {name: c, start: {position_m: [-1400, 900, 1560], heading_deg: 90}}
targets:
  - {name: e1, position_m: [1300, -800, 1560]}
  - {name: e2, position_m: [1300, 100, 1560]}
  - {name: e3, position_m: [1300, 1000, 1560]}
threats: []
simulation: {duration_s: 600}
)";

TEST(RealTerrainClearance, ReportedClearanceIsTheSourceDemsOnASharpRidgeInDegrees) {
  const fs::path dir = testing_support::fresh_test_dir();
  const world::RasterGrid dem = ridge_dem();
  io::write_dem_geotiff(dir / "ridge.tif", dem, 4326);
  std::ofstream(dir / "ridge.yaml") << kScenario;
  ASSERT_EQ(run_cli("run --quiet --scenario " + (dir / "ridge.yaml").string() + " --out " +
                        (dir / "run").string(),
                    dir / "run.log"),
            0)
      << slurp(dir / "run.log");
  const json metrics = json::parse(slurp(dir / "run" / "metrics.json"));

  // The local frame's definition (DESIGN §8), handed to PROJ itself.
  PJ_CONTEXT* ctx = proj_context_create();
  PJ* raw = proj_create_crs_to_crs(
      ctx, "+proj=tmerc +lat_0=37.3 +lon_0=-113 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m",
      "EPSG:4326", nullptr);
  ASSERT_NE(raw, nullptr);
  PJ* to_geo = proj_normalize_for_visualization(ctx, raw);  // (lon, lat) order
  proj_destroy(raw);
  ASSERT_NE(to_geo, nullptr);

  std::map<std::string, double> recheck;
  std::istringstream csv(slurp(dir / "run" / "trajectories.csv"));
  std::string line;
  std::getline(csv, line);  // t,uav,x,y,z,...
  int rows = 0;
  while (std::getline(csv, line)) {
    std::istringstream row(line);
    std::string t, uav, x, y, z;
    std::getline(row, t, ',');
    std::getline(row, uav, ',');
    std::getline(row, x, ',');
    std::getline(row, y, ',');
    std::getline(row, z, ',');
    const PJ_COORD geo =
        proj_trans(to_geo, PJ_FWD, proj_coord(std::stod(x), std::stod(y), 0.0, 0.0));
    const double clearance = std::stod(z) - source_height(dem, geo.xy.x, geo.xy.y);
    auto [it, inserted] = recheck.try_emplace(uav, clearance);
    it->second = std::min(it->second, clearance);
    ++rows;
  }
  proj_destroy(to_geo);
  proj_context_destroy(ctx);
  ASSERT_GT(rows, 1000);

  ASSERT_EQ(metrics["uavs"].size(), 3u);
  double closest = std::numeric_limits<double>::infinity();
  for (const json& u : metrics["uavs"]) {
    const std::string name = u["name"].get<std::string>();
    ASSERT_TRUE(recheck.count(name)) << name;
    const double reported = u["min_terrain_clearance_m"].get<double>();
    EXPECT_NEAR(reported, recheck[name], 0.5) << name;
    EXPECT_GE(recheck[name], 30.0 - 0.5) << name;  // h_safe on the source DEM
    closest = std::min(closest, recheck[name]);
  }
  // The flights did pass close over the crest: the check above compared where it matters.
  EXPECT_LT(closest, 30.0 + 40.0);
  EXPECT_EQ(metrics["terrain_collisions"].get<int>(), 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ridgeline
