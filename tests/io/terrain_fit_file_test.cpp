#include "io/terrain_fit_file.hpp"

#include <gtest/gtest.h>

#include "support/temp_dir.hpp"
#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "core/error.hpp"
#include "world/terrain.hpp"

namespace ridgeline::io {
namespace {

namespace fs = std::filesystem;

world::TerrainFitResult sample_fit() {
  world::TerrainFitResult fit;
  fit.status = world::TerrainFitStatus::kConverged;
  fit.terrain.combination = world::PeakCombination::kMax;
  fit.terrain.base_elevation_m = 12.5;
  fit.terrain.model_error_m = 3.2;
  fit.terrain.peaks = {{500.0, 600.0, 250.0, 150.0, 200.0}, {0.1, 1234567.891, 80.0, 90.5, 100.0}};
  fit.rmse_m = 1.01;
  fit.max_residual_m = 3.2;
  fit.iterations = 9;
  fit.time_s = 0.25;
  return fit;
}

world::RasterGrid grid_of(int rows, int cols) {
  world::RasterGrid grid;
  grid.rows = rows;
  grid.cols = cols;
  grid.heights_m.assign(static_cast<std::size_t>(rows) * cols, 0.0);
  return grid;
}

TEST(TerrainFitFileTest, YamlFollowsTheSchemaAndRoundTripsValues) {
  const YAML::Node root = YAML::Load(terrain_fit_yaml(sample_fit(), "dem.tif", grid_of(30, 40)));
  const YAML::Node terrain = root["terrain"];
  ASSERT_TRUE(terrain.IsMap());
  EXPECT_EQ(terrain["combination"].as<std::string>(), "max");
  EXPECT_DOUBLE_EQ(terrain["base_elevation_m"].as<double>(), 12.5);
  EXPECT_DOUBLE_EQ(terrain["model_error_m"].as<double>(), 3.2);
  ASSERT_EQ(terrain["peaks"].size(), 2u);
  const YAML::Node p = terrain["peaks"][1];
  EXPECT_DOUBLE_EQ(p["x_m"].as<double>(), 0.1);
  // 10 significant digits keep millimetres of a 10^6 m coordinate.
  EXPECT_NEAR(p["y_m"].as<double>(), 1234567.891, 1e-3);
  EXPECT_DOUBLE_EQ(p["height_m"].as<double>(), 80.0);
  EXPECT_DOUBLE_EQ(p["sigma_x_m"].as<double>(), 90.5);
  EXPECT_DOUBLE_EQ(p["sigma_y_m"].as<double>(), 100.0);
  EXPECT_EQ(terrain.size(), 4u);  // nothing beyond the schema
  const YAML::Node report = root["fit_report"];
  EXPECT_EQ(report["dem"].as<std::string>(), "dem.tif");
  EXPECT_DOUBLE_EQ(report["rmse_m"].as<double>(), 1.01);
  EXPECT_DOUBLE_EQ(report["max_residual_m"].as<double>(), 3.2);
  EXPECT_EQ(report["iterations"].as<int>(), 9);
  EXPECT_DOUBLE_EQ(report["time_s"].as<double>(), 0.25);
  EXPECT_EQ(report["raster_cols"].as<int>(), 40);
  EXPECT_EQ(report["raster_rows"].as<int>(), 30);
  EXPECT_EQ(root.size(), 2u);
}

TEST(TerrainFitFileTest, SumCombinationIsNamedSum) {
  world::TerrainFitResult fit = sample_fit();
  fit.terrain.combination = world::PeakCombination::kSum;
  const YAML::Node root = YAML::Load(terrain_fit_yaml(fit, "x.asc", grid_of(2, 2)));
  EXPECT_EQ(root["terrain"]["combination"].as<std::string>(), "sum");
}

TEST(TerrainFitFileTest, WritesAtomicallyAndLeavesNoTemporary) {
  const fs::path dir = testing_support::fresh_test_dir();
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path file = dir / "terrain.yaml";
  write_terrain_fit_yaml(file, sample_fit(), "dem.tif", grid_of(3, 3));
  EXPECT_TRUE(fs::exists(file));
  EXPECT_FALSE(fs::exists(dir / "terrain.yaml.tmp"));
  EXPECT_EQ(YAML::LoadFile(file.string())["terrain"]["peaks"].size(), 2u);
  // A path whose parent is a regular file cannot be written: an InputError, no file left.
  const fs::path blocked = file / "nested.yaml";
  EXPECT_THROW(write_terrain_fit_yaml(blocked, sample_fit(), "dem.tif", grid_of(3, 3)), InputError);
  EXPECT_FALSE(fs::exists(blocked));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ridgeline::io
