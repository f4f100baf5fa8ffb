// Scenarios with a geodetic origin (io/scenario_file.hpp, io/geo_frame.hpp): lat/lon/alt
// positions, a DEM in EPSG:4326 warped into the local frame, and an altitude band stated
// above home over a valley whose floor is 800 m above sea level. The terrain reference is an
// analytic function of latitude and longitude, evaluated here without any raster code.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.hpp"
#include "io/dem_file.hpp"
#include "io/geo_frame.hpp"
#include "io/scenario_file.hpp"
#include "io/scenario_summary.hpp"
#include "mission/stage_inputs.hpp"
#include "planning/global_planner.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline::io {
namespace {

namespace fs = std::filesystem;

double valley_height(double lat_deg, double lon_deg) {
  const double u = (lat_deg - 46.525) / 0.004, v = (lon_deg - 7.955) / 0.006;
  const double ridge = (lat_deg - 46.505) / 0.003;
  return 800.0 + 250.0 * std::exp(-0.5 * (u * u + v * v)) + 120.0 * std::exp(-0.5 * ridge * ridge);
}

void write_valley_dem(const fs::path& path) {
  world::RasterGrid g;
  g.cell_x_m = g.cell_y_m = 1.0 / 3600.0;  // degrees: 1 arc-second, like SRTM1
  g.cols = 288;
  g.rows = 216;
  g.origin_x_m = 7.92 + 0.5 * g.cell_x_m;
  g.origin_y_m = 46.49 + 0.5 * g.cell_y_m;
  g.heights_m.resize(static_cast<std::size_t>(g.rows) * g.cols);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) g.at(r, c) = valley_height(g.y_of_row(r), g.x_of_col(c));
  write_dem_geotiff(path, g, 4326);
}

std::string scenario_yaml(const std::string& origin_line, const std::string& altitude_line) {
  return origin_line + "\n" + altitude_line + R"(
name: valley
area: {x_min_m: -1500, x_max_m: 1500, y_min_m: -1500, y_max_m: 1500}
safety: {terrain_clearance_m: 20, separation_m: 10, threat_margin_m: 10}
terrain: {dem: {path: valley.tif, model: raster}}
uavs:
  - name: a
    start: {position_geo: {lat_deg: 46.5092, lon_deg: 7.9443, alt_amsl_m: 950}, heading_deg: 45}
  - name: b
    start: {position_m: [-1150, -1230, 950], heading_deg: 45}
targets:
  - {name: north, position_m: [1000, 1000, 900]}
  - {name: east, position_geo: {lat_deg: 46.53, lon_deg: 7.975, alt_amsl_m: 950}}
threats:
  - {name: t1, centre_geo: {lat_deg: 46.52, lon_deg: 7.96, alt_amsl_m: 1000}, velocity_m_s: [3, 0, 0], radius_m: 40, appear_s: 500, vanish_s: 600}
planner: {waypoints_per_uav: 40}
)";
}

const std::string kOrigin = "origin: {lat_deg: 46.52, lon_deg: 7.96, alt_amsl_m: 800}";
const std::string kHomeBand = "altitude: {min_m: 40, max_m: 500, reference: home}";

class GeoScenario : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing_support::fresh_test_dir();
    write_valley_dem(dir_ / "valley.tif");
  }
  void TearDown() override { fs::remove_all(dir_); }
  LoadedScenario load(const std::string& yaml) { return load_scenario(yaml, "geo.yaml", dir_); }
  fs::path dir_;
};

TEST_F(GeoScenario, LatLonPositionsAndHomeBandAreInTheLocalFrameAboveSeaLevel) {
  const LoadedScenario loaded = load(scenario_yaml(kOrigin, kHomeBand));
  const mission::Scenario& s = loaded.scenario;
  ASSERT_TRUE(s.origin.has_value());
  EXPECT_DOUBLE_EQ(s.safety.altitude.min_m, 840.0);
  EXPECT_DOUBLE_EQ(s.safety.altitude.max_m, 1300.0);
  const GeoFrame frame(*s.origin);
  const Vec3 a = frame.to_local({46.5092, 7.9443, 950.0});
  EXPECT_LT((s.uavs[0].start_position_m - a).norm(), 1e-9);
  EXPECT_LT((s.threats[0].centre_m - Vec3(0.0, 0.0, 1000.0)).norm(), 1e-6);
  // The summary (summary.json, `validate`) says where heights are measured from.
  const nlohmann::json summary = summarize(loaded);
  EXPECT_EQ(summary["frame"]["z"], "metres above mean sea level");
  EXPECT_EQ(summary["frame"]["altitude_stated_above"], "home");
  EXPECT_NE(summary_text(summary).find("altitude band 840..1300 m AMSL (stated above home)"),
            std::string::npos)
      << summary_text(summary);
  // The terrain is the DEM's real elevation wherever it is asked.
  for (const Vec3& p :
       {Vec3(0, 0, 0), Vec3(-1200, -1200, 0), Vec3(-383, 556, 0), Vec3(900, -700, 0)}) {
    const GeoPoint g = frame.to_geodetic(p);
    EXPECT_NEAR(loaded.terrain->height(p.x(), p.y()), valley_height(g.lat_deg, g.lon_deg), 0.5);
  }
}

TEST_F(GeoScenario, PlansOverTheRealElevationsWithTheBandAboveHome) {
  const LoadedScenario loaded = load(scenario_yaml(kOrigin, kHomeBand));
  const planning::GlobalPlan plan =
      planning::plan_mission(mission::make_planning_problem(loaded.scenario, loaded.terrain),
                             mission::make_planner_options(loaded.scenario));
  ASSERT_EQ(plan.status, planning::GlobalPlanStatus::kPlanned) << plan.message;
  const GeoFrame frame(*loaded.scenario.origin);
  double min_clearance = 1e9;
  for (const planning::UavPlan& u : plan.uavs) {
    for (const mpc::ReferencePoint& r : u.timing.samples) {
      const GeoPoint g = frame.to_geodetic(r.position_m);
      min_clearance =
          std::min(min_clearance, r.position_m.z() - valley_height(g.lat_deg, g.lon_deg));
      ASSERT_GE(r.position_m.z(), 840.0 - 1e-6);
      ASSERT_LE(r.position_m.z(), 1300.0 + 1e-6);
    }
  }
  // h_safe 20 m on the real elevations, less the DEM's interpolation error (< 0.5 m here).
  EXPECT_GE(min_clearance, 20.0 - 0.5);
  EXPECT_GE(plan.validation.min_terrain_clearance_m, 20.0 - 1e-6);
}

TEST_F(GeoScenario, TheSameBandAboveTheDatumIsRejectedNamingTheField) {
  try {
    (void)load(scenario_yaml(kOrigin, "altitude: {min_m: 40, max_m: 500}"));
    FAIL() << "UAVs at 950 m AMSL were accepted in a 40..500 m band";
  } catch (const InvalidScenario& e) {
    EXPECT_NE(std::string(e.what()).find("altitude band"), std::string::npos) << e.what();
  }
}

TEST_F(GeoScenario, WithoutAnOriginTheDegreeDemAndLatLonAreErrors) {
  // Lat/lon positions first: the parser names the field.
  try {
    (void)load(scenario_yaml("", "altitude: {min_m: 840, max_m: 1300}"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "uavs[0].start.position_geo");
    EXPECT_NE(e.reason().find("geodetic origin"), std::string::npos) << e.what();
  }
  // Only metric positions: the DEM in degrees is refused, never read as metres.
  std::string yaml = scenario_yaml("", "altitude: {min_m: 840, max_m: 1300}");
  yaml.replace(
      yaml.find("{position_geo: {lat_deg: 46.5092, lon_deg: 7.9443, alt_amsl_m: 950}"),
      std::string("{position_geo: {lat_deg: 46.5092, lon_deg: 7.9443, alt_amsl_m: 950}").size(),
      "{position_m: [-1200, -1200, 950]");
  yaml.replace(
      yaml.find("position_geo: {lat_deg: 46.53, lon_deg: 7.975, alt_amsl_m: 950}"),
      std::string("position_geo: {lat_deg: 46.53, lon_deg: 7.975, alt_amsl_m: 950}").size(),
      "position_m: [1150, 1100, 950]");
  yaml.replace(yaml.find("centre_geo: {lat_deg: 46.52, lon_deg: 7.96, alt_amsl_m: 1000}"),
               std::string("centre_geo: {lat_deg: 46.52, lon_deg: 7.96, alt_amsl_m: 1000}").size(),
               "centre_m: [0, 0, 1000]");
  try {
    (void)load(yaml);
    FAIL() << "a DEM in degrees was loaded without an origin";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.dem.path");
    EXPECT_NE(e.reason().find("geodetic origin"), std::string::npos) << e.what();
  }
  // A home-relative band needs the origin too.
  try {
    (void)load(scenario_yaml("", kHomeBand));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "altitude.reference");
  }
}

TEST_F(GeoScenario, AnAreaBeyondTheDemIsAnErrorNotInventedTerrain) {
  // The warped DEM spans about ±3 km around the origin; a 4 km half-width does not fit.
  std::string yaml = scenario_yaml(kOrigin, kHomeBand);
  const std::string area = "area: {x_min_m: -1500, x_max_m: 1500, y_min_m: -1500, y_max_m: 1500}";
  yaml.replace(yaml.find(area), area.size(),
               "area: {x_min_m: -1500, x_max_m: 4000, y_min_m: -1500, y_max_m: 1500}");
  try {
    (void)load(yaml);
    FAIL() << "an area beyond the DEM was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "area");
    EXPECT_NE(e.reason().find("beyond the DEM"), std::string::npos) << e.what();
  }
}

TEST_F(GeoScenario, BadOriginAndPositionValuesNameTheirFields) {
  try {
    (void)load(
        scenario_yaml("origin: {lat_deg: 146.52, lon_deg: 7.96, alt_amsl_m: 800}", kHomeBand));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "origin.lat_deg");
  }
  try {
    (void)load(scenario_yaml("origin: {lat_deg: 46.52, alt_amsl_m: 800}", kHomeBand));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lon_deg"), std::string::npos) << e.what();
  }
  std::string both = scenario_yaml(kOrigin, kHomeBand);
  both.replace(both.find("{name: north, position_m: [1000, 1000, 900]}"),
               std::string("{name: north, position_m: [1000, 1000, 900]}").size(),
               "{name: north, position_m: [1000, 1000, 900], position_geo: {lat_deg: 46.5, "
               "lon_deg: 7.9, alt_amsl_m: 900}}");
  try {
    (void)load(both);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "targets[0]");
    EXPECT_NE(e.reason().find("exactly one"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ridgeline::io
