// Runs the `ridgeline fit-dem` program (RIDGELINE_CLI_PATH) end to end.
#include <gtest/gtest.h>

#include "support/temp_dir.hpp"
#include <sys/wait.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "io/dem_file.hpp"
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

}  // namespace
}  // namespace ridgeline::apps
