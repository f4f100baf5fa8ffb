// Runs the `ridgeline fit-dem` program (RIDGELINE_CLI_PATH) end to end.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/error.hpp"
#include "io/dem_file.hpp"
#include "io/scenario_file.hpp"
#include "support/temp_dir.hpp"
#include "world/terrain.hpp"

namespace ridgeline::apps {
namespace {

namespace fs = std::filesystem;

struct CliRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

CliRun run_cli(const std::string& args, const fs::path& log) {
  const std::string command =
      std::string(RIDGELINE_CLI_PATH) + " " + args + " > '" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  CliRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  run.output = text.str();
  return run;
}

class FitDemCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing_support::fresh_test_dir();
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

world::PeakTerrainConfig three_peaks() {
  world::PeakTerrainConfig config;
  config.base_elevation_m = 50.0;
  config.peaks = {{400.0, 500.0, 200.0, 150.0, 120.0},
                  {1100.0, 900.0, 150.0, 130.0, 160.0},
                  {600.0, 1300.0, 100.0, 100.0, 90.0}};
  return config;
}

TEST_F(FitDemCommandTest, FitsAProjectedDemAndWritesTheTerrainYaml) {
  // A UTM DEM whose south-west corner is (500 000, 5 200 000): local = projected − corner.
  world::PeakTerrainConfig shifted = three_peaks();
  for (world::Peak& p : shifted.peaks) {
    p.x_m += 500'000.0;
    p.y_m += 5'200'000.0;
  }
  const world::RasterGrid grid = world::sample_terrain(
      world::PeakTerrain(shifted), 161, 161, Vec2(500'005.0, 5'200'005.0), Vec2(10.0, 10.0));
  const fs::path dem = dir_ / "dem.tif";
  io::write_dem_geotiff(dem, grid, 32632);
  const fs::path out = dir_ / "terrain.yaml";
  const CliRun run =
      run_cli("fit-dem --dem '" + dem.string() + "' --peaks 3 --out '" + out.string() + "'",
              dir_ / "log.txt");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("RMSE"), std::string::npos) << run.output;
  const YAML::Node root = YAML::LoadFile(out.string());
  EXPECT_EQ(root["terrain"]["combination"].as<std::string>(), "max");
  ASSERT_EQ(root["terrain"]["peaks"].size(), 3u);
  // Noise-free data from the model family: the highest peak is found at its local position
  // to well under a cell (10 m).
  const YAML::Node top = root["terrain"]["peaks"][0];
  EXPECT_NEAR(top["x_m"].as<double>(), 400.0, 1.0);
  EXPECT_NEAR(top["y_m"].as<double>(), 500.0, 1.0);
  EXPECT_NEAR(top["height_m"].as<double>(), 200.0, 1.0);
  EXPECT_LT(root["fit_report"]["rmse_m"].as<double>(), 0.5);
  EXPECT_EQ(root["fit_report"]["raster_cols"].as<int>(), 161);
  EXPECT_FALSE(fs::exists(dir_ / "terrain.yaml.tmp"));
}

TEST_F(FitDemCommandTest, MissingDemIsAnInputErrorNamingTheFile) {
  const fs::path out = dir_ / "terrain.yaml";
  const CliRun run = run_cli("fit-dem --dem '" + (dir_ / "nowhere.tif").string() +
                                 "' --peaks 3 --out '" + out.string() + "'",
                             dir_ / "log.txt");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("nowhere.tif"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(FitDemCommandTest, ZeroPeaksIsRejected) {
  const fs::path dem = dir_ / "dem.asc";
  io::write_dem_ascii_grid(dem, world::sample_terrain(world::PeakTerrain(three_peaks()), 20, 20,
                                                      Vec2(0.0, 0.0), Vec2(80.0, 80.0)));
  const fs::path out = dir_ / "terrain.yaml";
  const CliRun run =
      run_cli("fit-dem --dem '" + dem.string() + "' --peaks 0 --out '" + out.string() + "'",
              dir_ / "log.txt");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("--peaks"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(FitDemCommandTest, GeographicDemIsRejected) {
  world::RasterGrid grid = world::sample_terrain(world::PeakTerrain(three_peaks()), 20, 20,
                                                 Vec2(0.0, 0.0), Vec2(80.0, 80.0));
  grid.origin_x_m = 8.5;
  grid.origin_y_m = 46.5;
  grid.cell_x_m = grid.cell_y_m = 1.0 / 1200.0;
  const fs::path dem = dir_ / "wgs84.tif";
  io::write_dem_geotiff(dem, grid, 4326);
  const fs::path out = dir_ / "terrain.yaml";
  const CliRun run =
      run_cli("fit-dem --dem '" + dem.string() + "' --peaks 2 --out '" + out.string() + "'",
              dir_ / "log.txt");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("geodetic origin"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(out));
}

// With --origin a DEM in degrees is fitted in that origin's frame, the file records the origin,
// and a scenario may include it only with the same origin.
TEST_F(FitDemCommandTest, GeographicDemFitsAroundAnOriginThatScenariosMustShare) {
  world::RasterGrid grid = world::sample_terrain(world::PeakTerrain(three_peaks()), 20, 20,
                                                 Vec2(0.0, 0.0), Vec2(80.0, 80.0));
  grid.origin_x_m = 8.5;
  grid.origin_y_m = 46.5;
  grid.cell_x_m = grid.cell_y_m = 1.0 / 1200.0;
  const fs::path dem = dir_ / "wgs84.tif";
  io::write_dem_geotiff(dem, grid, 4326);
  const fs::path fitted = dir_ / "terrain.yaml", plain = dir_ / "plain.yaml";
  const CliRun run =
      run_cli("fit-dem --dem '" + dem.string() + "' --peaks 2 --origin 46.508,8.508,40 --out '" +
                  fitted.string() + "'",
              dir_ / "log.txt");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const YAML::Node file = YAML::LoadFile(fitted.string());
  EXPECT_DOUBLE_EQ(file["fit_report"]["origin"]["lat_deg"].as<double>(), 46.508);
  EXPECT_DOUBLE_EQ(file["fit_report"]["origin"]["lon_deg"].as<double>(), 8.508);
  // The DEM spans about 1.3 km x 1.9 km around the origin: the peaks are placed in metres
  // around it, not at the raster's corner and not in degrees.
  for (const auto& peak : file["terrain"]["peaks"]) {
    EXPECT_LT(std::abs(peak["x_m"].as<double>()), 1500.0);
    EXPECT_LT(std::abs(peak["y_m"].as<double>()), 1500.0);
  }
  auto scenario = [&](const std::string& origin, const fs::path& terrain) {
    return origin +
           "\nname: s\narea: {x_min_m: -300, x_max_m: 300, y_min_m: -300, y_max_m: 300}\n"
           "terrain: {include: " +
           terrain.filename().string() +
           "}\nuavs: [{name: a, start: {position_m: [0, 0, 400]}}]\n"
           "targets: [{name: t, position_m: [100, 100, 400]}]\n";
  };
  const std::string same = "origin: {lat_deg: 46.508, lon_deg: 8.508, alt_amsl_m: 40}";
  EXPECT_NO_THROW((void)io::load_scenario(scenario(same, fitted), "s.yaml", dir_));
  try {
    (void)io::load_scenario(scenario("", fitted), "s.yaml", dir_);
    FAIL() << "a terrain fitted around an origin was used without one";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.include");
  }
  try {
    (void)io::load_scenario(
        scenario("origin: {lat_deg: 46.51, lon_deg: 8.508, alt_amsl_m: 40}", fitted), "s.yaml",
        dir_);
    FAIL() << "a terrain fitted around another origin was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.include");
  }
  // A fit made in a projected DEM's own frame is refused by a scenario with an origin.
  const fs::path utm = dir_ / "utm.tif";
  world::RasterGrid metric = grid;
  metric.origin_x_m = 500'040.0;
  metric.origin_y_m = 5'200'040.0;
  metric.cell_x_m = metric.cell_y_m = 80.0;
  io::write_dem_geotiff(utm, metric, 32632);
  ASSERT_EQ(run_cli("fit-dem --dem '" + utm.string() + "' --peaks 2 --out '" + plain.string() + "'",
                    dir_ / "log2.txt")
                .exit_code,
            0);
  try {
    (void)io::load_scenario(scenario(same, plain), "s.yaml", dir_);
    FAIL() << "a terrain fitted in a DEM's corner frame was used in a geographic frame";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.include");
    EXPECT_NE(e.reason().find("--origin"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ridgeline::apps
