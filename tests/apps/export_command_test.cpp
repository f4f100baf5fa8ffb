// The geographic workflow as a user runs it: a scenario over an EPSG:4326 DEM with a geodetic
// origin is planned and flown (`ridgeline run`, which writes flight.geojson), its plan is
// exported (`ridgeline export`) to QGroundControl, GeoJSON, KML and CSV, and the files are
// read back by GDAL's own `ogrinfo` and by parsing; without an origin the same DEM is an
// error, and exports of an origin-less plan fail without writing anything.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "io/dem_file.hpp"
#include "io/geo_frame.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

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

// ogrinfo's summary: the number of features over all layers.
int ogr_feature_count(const fs::path& file, const fs::path& log) {
  const std::string cmd = "ogrinfo -ro -al -so " + file.string() + " >" + log.string() + " 2>&1";
  if (std::system(cmd.c_str()) != 0) return -1;
  const std::string text = slurp(log);
  const std::regex count("Feature Count: ([0-9]+)");
  int total = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), count);
       it != std::sregex_iterator(); ++it)
    total += std::stoi((*it)[1]);
  return total;
}

double valley_height(double lat_deg, double lon_deg) {
  const double u = (lat_deg - 46.525) / 0.004, v = (lon_deg - 7.955) / 0.006;
  return 800.0 + 250.0 * std::exp(-0.5 * (u * u + v * v));
}

void write_valley_dem(const fs::path& path) {
  world::RasterGrid g;
  g.cell_x_m = g.cell_y_m = 1.0 / 3600.0;  // degrees: 1 arc-second
  g.cols = 288;
  g.rows = 216;
  g.origin_x_m = 7.92 + 0.5 * g.cell_x_m;
  g.origin_y_m = 46.49 + 0.5 * g.cell_y_m;
  g.heights_m.resize(static_cast<std::size_t>(g.rows) * g.cols);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) g.at(r, c) = valley_height(g.y_of_row(r), g.x_of_col(c));
  io::write_dem_geotiff(path, g, 4326);
}

const char* kScenario = R"(
name: valley
origin: {lat_deg: 46.52, lon_deg: 7.96, alt_amsl_m: 800}
altitude: {min_m: 40, max_m: 400, reference: home}
area: {x_min_m: -1200, x_max_m: 1200, y_min_m: -1200, y_max_m: 1200}
terrain: {dem: {path: valley.tif, model: raster}}
uavs:
  - {name: a, start: {position_m: [-1000, -1000, 900], heading_deg: 45}}
  - {name: b, start: {position_geo: {lat_deg: 46.5112, lon_deg: 7.9470, alt_amsl_m: 900}, heading_deg: 45}}
targets:
  - {name: north, position_m: [-200, 900, 1050]}
  - {name: east, position_m: [900, 300, 900]}
threats:
  - {name: t1, centre_m: [0, -300, 950], velocity_m_s: [2, 1, 0], radius_m: 30, appear_s: 30, vanish_s: 400}
planner: {waypoints_per_uav: 40}
simulation: {duration_s: 400}
)";

class ExportCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing_support::fresh_test_dir();
    write_valley_dem(dir_ / "valley.tif");
    std::ofstream(dir_ / "geo.yaml") << kScenario;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(ExportCommand, GeoScenarioFliesAndEveryExportReadsBack) {
  const fs::path out = dir_ / "run";
  ASSERT_EQ(
      run_cli("run --quiet --scenario " + (dir_ / "geo.yaml").string() + " --out " + out.string(),
              dir_ / "run.log"),
      0)
      << slurp(dir_ / "run.log");
  const json metrics = json::parse(slurp(out / "metrics.json"));
  EXPECT_EQ(metrics["terrain_collisions"].get<int>(), 0);
  for (const json& u : metrics["uavs"])  // real elevations: the valley floor is at 800 m
    EXPECT_GE(u["min_terrain_clearance_m"].get<double>(), 20.0 - 0.5);
  // flight.geojson: one feature per UAV track, target and threat, for ogrinfo.
  EXPECT_EQ(ogr_feature_count(out / "flight.geojson", dir_ / "ogr1.log"), 2 + 2 + 1)
      << slurp(dir_ / "ogr1.log");
  const json flight = json::parse(slurp(out / "flight.geojson"));
  const io::GeoFrame frame({46.52, 7.96, 800.0});
  const json& first = flight["features"][0]["geometry"]["coordinates"][0];
  const Vec3 start =
      frame.to_local({first[1].get<double>(), first[0].get<double>(), first[2].get<double>()});
  EXPECT_LT((start - Vec3(-1000, -1000, 900)).norm(), 2.0);  // the first fix, noise 0.1 m

  const json plan = json::parse(slurp(out / "plan.json"));
  ASSERT_TRUE(plan["frame"]["origin"].is_object());
  const std::string plan_arg = "export --plan " + (out / "plan.json").string();
  ASSERT_EQ(run_cli(plan_arg + " --format qgc --out " + (dir_ / "m.plan").string(), dir_ / "q.log"),
            0)
      << slurp(dir_ / "q.log");
  for (const json& u : plan["uavs"]) {
    const json q = json::parse(slurp(dir_ / ("m-" + u["id"].get<std::string>() + ".plan")));
    EXPECT_EQ(q["fileType"], "Plan");
    ASSERT_EQ(q["mission"]["items"].size(), u["waypoints"].size());
    for (std::size_t k = 0; k < u["waypoints"].size(); ++k) {
      const json& p = q["mission"]["items"][k]["params"];
      const Vec3 local =
          frame.to_local({p[4].get<double>(), p[5].get<double>(), p[6].get<double>()});
      const json& w = u["waypoints"][k];
      ASSERT_LT((local - Vec3(w[0], w[1], w[2])).norm(), 1e-3);
      ASSERT_GT(p[6].get<double>(), 800.0);  // altitudes are AMSL over the 800 m valley
    }
  }
  for (const std::string format : {"geojson", "kml", "csv"}) {
    const fs::path file = dir_ / ("m." + format);
    ASSERT_EQ(run_cli(plan_arg + " --format " + format + " --out " + file.string(), dir_ / "e.log"),
              0)
        << slurp(dir_ / "e.log");
    // CSV: one row per vertex; the others one feature per UAV path, target and threat.
    std::size_t vertices = 0;
    for (const json& u : plan["uavs"]) vertices += u["waypoints"].size();
    const int expected = format == "csv" ? static_cast<int>(vertices) + 2 + 2 : 2 + 2 + 1;
    EXPECT_EQ(ogr_feature_count(file, dir_ / "ogr.log"), expected)
        << format << slurp(dir_ / "ogr.log");
  }
}

TEST_F(ExportCommand, WithoutOriginTheDegreeDemFailsAndExportsWriteNothing) {
  std::string yaml = kScenario;
  yaml.replace(yaml.find("origin:"), yaml.find('\n', yaml.find("origin:")) - yaml.find("origin:"),
               "");
  yaml.replace(yaml.find("reference: home"), std::string("reference: home").size(),
               "reference: datum");
  yaml.replace(
      yaml.find("{position_geo: {lat_deg: 46.5112, lon_deg: 7.9470, alt_amsl_m: 900}"),
      std::string("{position_geo: {lat_deg: 46.5112, lon_deg: 7.9470, alt_amsl_m: 900}").size(),
      "{position_m: [-970, -1030, 900]");
  std::ofstream(dir_ / "nogeo.yaml") << yaml;
  EXPECT_EQ(run_cli("run --quiet --scenario " + (dir_ / "nogeo.yaml").string() + " --out " +
                        (dir_ / "r").string(),
                    dir_ / "r.log"),
            2);
  const std::string log = slurp(dir_ / "r.log");
  EXPECT_NE(log.find("terrain.dem.path"), std::string::npos) << log;
  EXPECT_NE(log.find("geodetic origin"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(dir_ / "r" / "plan.json"));

  // A plan of the origin-less default scenario: no flight.geojson, and exports need --origin.
  const fs::path out = dir_ / "plain";
  ASSERT_EQ(run_cli("plan --out " + out.string(), dir_ / "p.log"), 0) << slurp(dir_ / "p.log");
  const std::string plan_arg = "export --plan " + (out / "plan.json").string();
  EXPECT_EQ(run_cli(plan_arg + " --format kml --out " + (dir_ / "x.kml").string(), dir_ / "x.log"),
            2);
  EXPECT_NE(slurp(dir_ / "x.log").find("geodetic origin"), std::string::npos)
      << slurp(dir_ / "x.log");
  EXPECT_FALSE(fs::exists(dir_ / "x.kml"));
  EXPECT_EQ(
      run_cli(plan_arg + " --format kml --origin 46.52,7.96,800 --out " + (dir_ / "x.kml").string(),
              dir_ / "x.log"),
      0)
      << slurp(dir_ / "x.log");
  EXPECT_EQ(ogr_feature_count(dir_ / "x.kml", dir_ / "ogr.log"), 3 + 3 + 3);
  EXPECT_EQ(
      run_cli(plan_arg + " --format qgc --origin 46.52,7.96 --out " + (dir_ / "y.plan").string(),
              dir_ / "y.log"),
      2);
  EXPECT_NE(slurp(dir_ / "y.log").find("--origin"), std::string::npos);
  EXPECT_EQ(run_cli(plan_arg + " --format gpx --out " + (dir_ / "y.gpx").string(), dir_ / "y.log"),
            2);
  EXPECT_NE(slurp(dir_ / "y.log").find("--format"), std::string::npos);
  EXPECT_EQ(run_cli(plan_arg + " --format qgc --uav nobody --origin 46.52,7.96,800 --out " +
                        (dir_ / "y.plan").string(),
                    dir_ / "y.log"),
            2);
  EXPECT_NE(slurp(dir_ / "y.log").find("nobody"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "y.plan"));
}

}  // namespace
}  // namespace ridgeline
