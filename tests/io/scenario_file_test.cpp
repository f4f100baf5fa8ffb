#include "io/scenario_file.hpp"

#include "io/dem_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/temp_dir.hpp"
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>

namespace ridgeline::io {
namespace {

using ::testing::HasSubstr;

// The default scenario's YAML, mutated by `edit`, then loaded. Returns the error's text, or
// "" when it loads.
std::string load_error(const std::function<void(YAML::Node&)>& edit) {
  YAML::Node root = YAML::Load(std::string(default_scenario_yaml()));
  edit(root);
  YAML::Emitter out;
  out << root;
  try {
    load_scenario(out.c_str(), "mutated.yaml", std::filesystem::temp_directory_path());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ScenarioFile, DefaultScenarioLoadsAndMatchesTheDesign) {
  const LoadedScenario loaded = load_default_scenario();
  const mission::Scenario& s = loaded.scenario;
  // DESIGN §7: 2 km square, 6–8 peaks of 80–300 m, 3 UAVs, 3 targets, 3 threats of 30–60 m
  // moving 2–8 m/s, 2 m/s mean wind, MPC at 50 Hz.
  EXPECT_DOUBLE_EQ(s.area.x_max_m - s.area.x_min_m, 2000.0);
  EXPECT_DOUBLE_EQ(s.area.y_max_m - s.area.y_min_m, 2000.0);
  ASSERT_GE(s.terrain.peaks.peaks.size(), 6u);
  ASSERT_LE(s.terrain.peaks.peaks.size(), 8u);
  for (const auto& p : s.terrain.peaks.peaks) {
    EXPECT_GE(p.height_m, 80.0);
    EXPECT_LE(p.height_m, 300.0);
  }
  EXPECT_EQ(s.uavs.size(), 3u);
  EXPECT_EQ(s.targets.size(), 3u);
  ASSERT_EQ(s.threats.size(), 3u);
  for (const auto& t : s.threats) {
    EXPECT_GE(t.radius_m, 30.0);
    EXPECT_LE(t.radius_m, 60.0);
    EXPECT_GE(t.velocity_m_s.norm(), 2.0);
    EXPECT_LE(t.velocity_m_s.norm(), 8.0);
  }
  EXPECT_NEAR(s.wind.mean_m_s.norm(), 2.0, 1e-9);
  EXPECT_NEAR(1.0 / s.mpc.control_period_s, 50.0, 1e-9);
  EXPECT_NEAR(s.uavs[0].vehicle.max_pitch_rad, deg_to_rad(30.0), 1e-12);
  EXPECT_DOUBLE_EQ(s.uavs[0].vehicle.min_speed_m_s(), 5.0);
  EXPECT_DOUBLE_EQ(s.uavs[0].vehicle.max_speed_m_s(), 15.0);
  // Starts in the south-west, targets in the north-east.
  for (const auto& u : s.uavs) EXPECT_LT(u.start_position_m.head<2>().norm(), 500.0);
  for (const auto& t : s.targets) EXPECT_GT(t.position_m.x() + t.position_m.y(), 2500.0);
}

TEST(ScenarioFile, UavVehicleBlockOverridesTheDefaults) {
  YAML::Node root = YAML::Load(std::string(default_scenario_yaml()));
  root["uavs"][1]["vehicle"]["tau_v_s"] = 0.9;
  YAML::Emitter out;
  out << root;
  const mission::Scenario s = parse_scenario(out.c_str(), "x.yaml", ".");
  EXPECT_DOUBLE_EQ(s.uavs[1].vehicle.tau_v_s, 0.9);
  EXPECT_DOUBLE_EQ(s.uavs[0].vehicle.tau_v_s, 0.5);
  EXPECT_DOUBLE_EQ(s.uavs[1].vehicle.cruise_speed_m_s, 10.0);  // others inherited
}

TEST(ScenarioFile, SeedDerivesTheWindSeedUnlessGiven) {
  YAML::Node root = YAML::Load(std::string(default_scenario_yaml()));
  YAML::Emitter a;
  a << root;
  root["seed"] = 7;
  YAML::Emitter b;
  b << root;
  root["wind"]["seed"] = 99;
  YAML::Emitter c;
  c << root;
  const auto sa = parse_scenario(a.c_str(), "a", "."), sb = parse_scenario(b.c_str(), "b", ".");
  EXPECT_NE(sa.wind.seed, sb.wind.seed);
  EXPECT_EQ(parse_scenario(c.c_str(), "c", ".").wind.seed, 99u);
}

TEST(ScenarioFile, MalformedYamlNamesLineAndColumn) {
  try {
    load_scenario("area: {x_min_m: 0,\nuavs: [", "broken.yaml", ".");
    FAIL() << "expected an error";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("broken.yaml:"));
    EXPECT_THAT(e.what(), HasSubstr("malformed YAML"));
  }
}

TEST(ScenarioFile, MissingKeyIsNamed) {
  EXPECT_THAT(load_error([](YAML::Node& r) { r.remove("targets"); }),
              HasSubstr("targets: is required but missing"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["threats"][1].remove("radius_m"); }),
              HasSubstr("threats[1].radius_m: is required but missing"));
}

TEST(ScenarioFile, MisspelledKeyIsRejectedWithASuggestion) {
  EXPECT_THAT(load_error([](YAML::Node& r) {
                r["threats"][0]["radus_m"] = 40;
                r["threats"][0].remove("radius_m");
              }),
              HasSubstr("threats[0].radius_m: is required"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["wind"]["gust_sdt_m_s"] = 1.0; }),
              HasSubstr("wind.gust_sdt_m_s: unknown key (did you mean 'gust_std_m_s'?)"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["colour"] = "red"; }),
              HasSubstr("colour: unknown key"));
}

TEST(ScenarioFile, WrongTypeIsNamed) {
  EXPECT_THAT(load_error([](YAML::Node& r) { r["uavs"][2]["sensor_range_m"] = "far"; }),
              HasSubstr("uavs[2].sensor_range_m: expected a number, got 'far'"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["targets"][0]["position_m"] = "here"; }),
              HasSubstr("targets[0].position_m: expected a list of three numbers"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["mpc"]["horizon_steps"] = 12.5; }),
              HasSubstr("mpc.horizon_steps: expected a whole number"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["uavs"] = 3; }),
              HasSubstr("uavs: expected a list"));
}

TEST(ScenarioFile, OptimizerReplanIsABooleanPlannerField) {
  // Off by default (the default scenario says false), on when set, and anything but a boolean
  // is one error naming the field.
  const mission::Scenario d = load_scenario(std::string(default_scenario_yaml()), "default.yaml",
                                            std::filesystem::temp_directory_path())
                                  .scenario;
  EXPECT_FALSE(d.planner.optimizer_replan);
  YAML::Node root = YAML::Load(std::string(default_scenario_yaml()));
  root["planner"]["optimizer_replan"] = true;
  YAML::Emitter out;
  out << root;
  EXPECT_TRUE(load_scenario(out.c_str(), "on.yaml", std::filesystem::temp_directory_path())
                  .scenario.planner.optimizer_replan);
  EXPECT_THAT(load_error([](YAML::Node& r) { r["planner"]["optimizer_replan"] = "sometimes"; }),
              HasSubstr("planner.optimizer_replan: expected true or false"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["planner"]["optimizer_replan"] = 1.5; }),
              HasSubstr("planner.optimizer_replan: expected true or false"));
  EXPECT_THAT(
      load_error([](YAML::Node& r) { r["planner"]["optimiser_replan"] = true; }),
      HasSubstr("planner.optimiser_replan: unknown key (did you mean 'optimizer_replan'?)"));
}

TEST(ScenarioFile, NanAndInfinityAreRejected) {
  EXPECT_THAT(load_error([](YAML::Node& r) { r["wind"]["mean_m_s"][0] = ".nan"; }),
              HasSubstr("wind.mean_m_s[0]: must be a finite number"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["area"]["x_max_m"] = ".inf"; }),
              HasSubstr("area.x_max_m: must be a finite number"));
}

TEST(ScenarioFile, NegativeRadiusAndTimeConstantAreRejected) {
  EXPECT_THAT(load_error([](YAML::Node& r) { r["threats"][2]["radius_m"] = -5; }),
              HasSubstr("threats[2].radius_m: must be > 0, got -5"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["vehicle"]["tau_omega_s"] = -0.1; }),
              HasSubstr("uavs[0].vehicle.tau_omega_s: must be positive"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["terrain"]["peaks"][3]["sigma_x_m"] = 0; }),
              HasSubstr("terrain.peaks[3].sigma_x_m: must be positive"));
  EXPECT_THAT(
      load_error([](YAML::Node& r) { r["planner"]["allocation"]["makespan_weight"] = -2; }),
      HasSubstr("planner.allocation.makespan_weight: must not be negative, got -2"));
}

TEST(ScenarioFile, MinAboveMaxIsRejected) {
  EXPECT_THAT(load_error([](YAML::Node& r) { r["altitude"]["min_m"] = 600; }),
              HasSubstr("altitude.min_m: 600 must be below altitude.max_m (500)"));
  EXPECT_THAT(load_error([](YAML::Node& r) {
                r["threats"][0]["vanish_s"] = 10;
              }),
              HasSubstr("threats[0].vanish_s: must be later than appear_s (20), got 10"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["mpc"]["control_horizon_steps"] = 50; }),
              HasSubstr("mpc.control_horizon_steps: must be in [1, horizon_steps = 40]"));
}

TEST(ScenarioFile, TargetInsideTheTerrainClearanceIsRejectedWithTheNumbers) {
  // The tallest default peak is 300 m high at (900, 1250).
  const std::string error = load_error([](YAML::Node& r) {
    r["targets"][2]["position_m"] = std::vector<double>{900, 1250, 250};
  });
  EXPECT_THAT(error, HasSubstr("targets[2].position_m: 70.0 m below the terrain clearance "
                               "(terrain 300.0 m + h_safe 20 m): it is inside the terrain"));
}

TEST(ScenarioFile, StartInsideTheTerrainClearanceIsRejected) {
  EXPECT_THAT(load_error([](YAML::Node& r) {
                r["uavs"][0]["start"]["position_m"] = std::vector<double>{600, 700, 230};
              }),
              HasSubstr("uavs[0].start.position_m: 10.0 m below the terrain clearance"));
}

TEST(ScenarioFile, OtherConsistencyChecks) {
  EXPECT_THAT(load_error([](YAML::Node& r) { r["uavs"][1]["name"] = "uav1"; }),
              HasSubstr("uavs[1].name: 'uav1' is used twice"));
  EXPECT_THAT(load_error([](YAML::Node& r) {
                r["uavs"][1]["start"]["position_m"] = std::vector<double>{103, 133, 60};
              }),
              HasSubstr("uavs[1].start.position_m: 4.2 m from uavs[0] ('uav1'), closer than"));
  EXPECT_THAT(load_error([](YAML::Node& r) {
                r["targets"][0]["position_m"] = std::vector<double>{2500, 1000, 100};
              }),
              HasSubstr("targets[0].position_m: (2500.0, 1000.0) is outside the area"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["terrain"]["combination"] = "min"; }),
              HasSubstr("terrain.combination: must be 'max' or 'sum', got 'min'"));
}

TEST(ScenarioFile, PerUavTargetsAndEndsAreReadAndChecked) {
  YAML::Node root = YAML::Load(std::string(default_scenario_yaml()));
  root["uavs"][2]["targets"] = std::vector<std::string>{"hut", "mast"};
  root["uavs"][2]["end"]["position_m"] = std::vector<double>{160, 70, 60};
  YAML::Emitter out;
  out << root;
  const mission::Scenario s = load_scenario(out.c_str(), "missions.yaml", ".").scenario;
  EXPECT_EQ(s.uavs[2].assigned_targets, (std::vector<std::string>{"hut", "mast"}));
  ASSERT_TRUE(s.uavs[2].end_position_m.has_value());
  EXPECT_EQ(*s.uavs[2].end_position_m, Vec3(160, 70, 60));
  EXPECT_FALSE(s.uavs[0].end_position_m.has_value());
  EXPECT_TRUE(s.uavs[0].assigned_targets.empty());

  EXPECT_THAT(load_error([](YAML::Node& r) {
                r["uavs"][0]["targets"] = std::vector<std::string>{"mast", "chimney"};
              }),
              HasSubstr("uavs[0].targets[1]: no target is named 'chimney'"));
  EXPECT_THAT(load_error([](YAML::Node& r) {
                r["uavs"][0]["targets"] = std::vector<std::string>{"mast"};
                r["uavs"][2]["targets"] = std::vector<std::string>{"ridge", "mast"};
              }),
              HasSubstr("uavs[2].targets[1]: target 'mast' is already given to uavs[0] ('uav1')"));
  // An end inside the tallest peak (300 m at (900, 1250)).
  EXPECT_THAT(load_error([](YAML::Node& r) {
                r["uavs"][1]["end"]["position_m"] = std::vector<double>{900, 1250, 250};
              }),
              HasSubstr("uavs[1].end.position_m: 70.0 m below the terrain clearance"));
  EXPECT_THAT(load_error([](YAML::Node& r) { r["uavs"][1]["end"]["position"] = 3; }),
              HasSubstr("uavs[1].end"));
}

TEST(ScenarioFile, AllProblemsAreCollected) {
  YAML::Node root = YAML::Load(std::string(default_scenario_yaml()));
  root["threats"][0]["radius_m"] = -1;
  root["threats"][1]["radius_m"] = -2;
  YAML::Emitter out;
  out << root;
  try {
    load_scenario(out.c_str(), "two.yaml", ".");
    FAIL();
  } catch (const InvalidScenario& e) {
    ASSERT_EQ(e.problems().size(), 2u);
    EXPECT_EQ(e.problems()[1].field(), "threats[1].radius_m");
    EXPECT_THAT(e.what(), HasSubstr("(and 1 more problem)"));
  }
}

TEST(ScenarioFile, MissingFileIsNamed) {
  try {
    load_scenario_file("/nonexistent/dir/scenario.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/dir/scenario.yaml"));
    EXPECT_THAT(e.what(), HasSubstr("cannot read"));
  }
}

TEST(ScenarioFile, TerrainIncludeIsResolvedAgainstTheScenarioFolder) {
  const auto dir = testing_support::fresh_test_dir();
  {
    std::ofstream t(dir / "fitted.yaml");
    t << "terrain:\n  combination: sum\n  base_elevation_m: 5\n  model_error_m: 2.5\n"
         "  peaks:\n    - {x_m: 1000, y_m: 1000, height_m: 100, sigma_x_m: 200, sigma_y_m: 200}\n"
         "fit_report: {rmse_m: 0.8}\n";
  }
  YAML::Node root = YAML::Load(std::string(default_scenario_yaml()));
  root["terrain"] = YAML::Load("{include: fitted.yaml}");
  YAML::Emitter out;
  out << root;
  const LoadedScenario loaded = load_scenario(out.c_str(), "s.yaml", dir);
  EXPECT_EQ(loaded.scenario.terrain.peaks.combination, world::PeakCombination::kSum);
  // 5 m base + 100 m peak at its centre.
  EXPECT_NEAR(loaded.terrain->height(1000, 1000), 105.0, 1e-9);
  EXPECT_DOUBLE_EQ(loaded.terrain->model_error_m(), 2.5);

  root["terrain"] = YAML::Load("{include: missing.yaml}");
  YAML::Emitter bad;
  bad << root;
  try {
    load_scenario(bad.c_str(), "s.yaml", dir);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("terrain.include: cannot read file"));
  }
  std::filesystem::remove_all(dir);
}

// A DEM sampled from the default peaks, at 20 m cells over the 2 km area, placed so that its
// local frame (origin at the raster's south-west corner) matches the scenario's.
class DemScenario : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing_support::fresh_test_dir();
    const LoadedScenario reference = load_default_scenario();
    peaks_ = reference.terrain;
    const world::RasterGrid grid = world::sample_terrain(*peaks_, 100, 100, Vec2(10, 10), Vec2(20, 20));
    write_dem_geotiff(dir_ / "utm.tif", grid, 32632);     // UTM 32N: metres
    write_dem_geotiff(dir_ / "degrees.tif", grid, 4326);  // the same numbers read as degrees
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string scenario_with_terrain(const std::string& terrain_yaml) {
    YAML::Node root = YAML::Load(std::string(default_scenario_yaml()));
    root["terrain"] = YAML::Load(terrain_yaml);
    YAML::Emitter out;
    out << root;
    return out.c_str();
  }

  std::filesystem::path dir_;
  std::shared_ptr<const world::Terrain> peaks_;
};

TEST_F(DemScenario, RasterTerrainFollowsTheDem) {
  const LoadedScenario loaded =
      load_scenario(scenario_with_terrain("{dem: {path: utm.tif, model: raster}}"), "s.yaml", dir_);
  // Bilinear interpolation of 20 m samples of peaks with σ ≥ 120 m: the error is below
  // (Δ²/8)·max|H''| ≈ 50·(2·300/120²) ≈ 2 m; at cell centres it is exact.
  double max_error = 0.0;
  for (double x = 100; x < 1900; x += 37) {
    for (double y = 100; y < 1900; y += 41)
      max_error = std::max(max_error, std::abs(loaded.terrain->height(x, y) - peaks_->height(x, y)));
  }
  EXPECT_LT(max_error, 2.5);
  EXPECT_NEAR(loaded.terrain->height(910, 1250), peaks_->height(910, 1250), 1e-6);
}

TEST_F(DemScenario, FittedTerrainRecoversThePeaksAndCarriesItsResidual) {
  const LoadedScenario loaded = load_scenario(
      scenario_with_terrain("{dem: {path: utm.tif, model: fitted, fit_peaks: 7}}"), "s.yaml", dir_);
  EXPECT_GT(loaded.terrain->model_error_m(), 0.0);
  EXPECT_LT(loaded.terrain->model_error_m(), 10.0);
  EXPECT_NEAR(loaded.terrain->height(900, 1250), 300.0, 10.0);
}

TEST_F(DemScenario, MissingAndGeographicDemsAreNamedErrors) {
  try {
    load_scenario(scenario_with_terrain("{dem: {path: nowhere.tif}}"), "s.yaml", dir_);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.dem.path");
    EXPECT_THAT(e.what(), HasSubstr("nowhere.tif"));
  }
  try {
    load_scenario(scenario_with_terrain("{dem: {path: degrees.tif}}"), "s.yaml", dir_);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.dem.path");
    EXPECT_THAT(e.what(), HasSubstr("geodetic origin"));
  }
}

}  // namespace
}  // namespace ridgeline::io
