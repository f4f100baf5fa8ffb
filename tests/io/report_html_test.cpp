// The HTML report's builder on a mission made up here (straight flights with a known tracking
// error, so every number in the data can be predicted): the data block holds what the figures
// draw, the page inlines the bundle and the data without letting either end its <script>
// early, and a missing or wrong plotly file is an error that names it and how to install it.
// That the page draws in a browser is checked by tests/apps/report_browser_test.cpp.
#include "io/report_html.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <string>

#include "core/error.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline::io {
namespace {

// Stands in for plotly.min.js: read_plotly_js accepts it (header and newPlot), and its marker
// is found in the page only if the bundle was inlined.
constexpr const char* kFakePlotly =
    "/* plotly.js v0-test BUNDLE-MARKER-7f3a */ window.Plotly = {newPlot: function () {}};";

struct Fixture {
  mission::Scenario scenario;
  world::PeakTerrain terrain{world::PeakTerrainConfig{{{400, 320, 150, 120, 100}}}};
  mission::MissionMetrics metrics;
  std::vector<mission::TrajectoryRow> rows;

  MissionReportInput input() const { return {scenario, terrain, metrics, rows}; }
};

// Two UAVs for 10 s at 50 Hz: "alpha" flies east at 10 m/s with its reference 1 m north of it
// (tracking error exactly 1 m); "bravo" hovers at (100, 500, 90) on its reference. Rows are
// interleaved by time, as the mission writes them.
Fixture straight_flights() {
  Fixture f;
  f.scenario.name = "straight";
  f.scenario.area = {0, 1000, 0, 800};
  mission::UavSpec a, b;
  a.name = "alpha";
  a.start_position_m = Vec3(0, 100, 80);
  b.name = "bravo";
  b.start_position_m = Vec3(100, 500, 90);
  f.scenario.uavs = {a, b};
  f.scenario.targets = {{"mast", Vec3(700, 600, 120), 1, 30}};
  f.scenario.threats = {{"t1", Vec3(500, 400, 100), Vec3(2, -1, 0), 40, 3, 8}};
  for (int k = 0; k <= 500; ++k) {
    const double t = 0.02 * k;
    mission::TrajectoryRow ra;
    ra.t_s = t;
    ra.uav = 0;
    ra.position_m = Vec3(10.0 * t, 100, 80);
    ra.reference_m = Vec3(10.0 * t, 101, 80);
    mission::TrajectoryRow rb;
    rb.t_s = t;
    rb.uav = 1;
    rb.position_m = rb.reference_m = Vec3(100, 500, 90);
    f.rows.push_back(ra);
    f.rows.push_back(rb);
  }
  for (const mission::UavSpec& u : f.scenario.uavs) {
    mission::UavMetrics m;
    m.name = u.name;
    f.metrics.uavs.push_back(m);
  }
  f.metrics.uavs[0].path_length_m = 100.0;
  f.metrics.uavs[0].tracking_mse_m2 = 1.0;
  f.metrics.threat_encounters = 2;
  f.metrics.avoidance_success_rate = 1.0;
  return f;
}

TEST(ReportData, TrajectoriesAreSampledEveryHalfSecondAtEachUavsStateThen) {
  const Fixture f = straight_flights();
  const nlohmann::json d = mission_report_data(f.input());
  // 0, 0.5, ..., 10 s: the last row falls on the grid, so no extra end time.
  ASSERT_EQ(d["times"].size(), 21u);
  ASSERT_EQ(d["uavs"].size(), 2u);
  const nlohmann::json& a = d["uavs"][0];
  EXPECT_EQ(a["name"], "alpha");
  for (const char* key : {"x", "y", "z", "ref_x", "ref_y", "ref_z"}) {
    ASSERT_EQ(a[key].size(), 21u) << key;
    ASSERT_EQ(d["uavs"][1][key].size(), 21u) << key;
  }
  for (std::size_t k = 0; k < 21; ++k) {
    const double t = d["times"][k];
    EXPECT_NEAR(t, 0.5 * static_cast<double>(k), 1e-9);
    // Positions are rounded to 1 cm: 0.005 m is the largest rounding error.
    EXPECT_NEAR(a["x"][k].get<double>(), 10.0 * t, 0.005) << "t " << t;
    EXPECT_NEAR(a["ref_y"][k].get<double>() - a["y"][k].get<double>(), 1.0, 0.01);
    EXPECT_NEAR(d["uavs"][1]["y"][k].get<double>(), 500.0, 0.005);
  }
}

TEST(ReportData, AnEndOffTheSampleGridIsAddedSoTheFinalPositionsAreShown) {
  Fixture f = straight_flights();
  ReportOptions options;
  options.sample_period_s = 3.0;  // 0, 3, 6, 9 and then the last row at 10 s
  const nlohmann::json d = mission_report_data(f.input(), options);
  ASSERT_EQ(d["times"].size(), 5u);
  EXPECT_NEAR(d["times"][4].get<double>(), 10.0, 1e-9);
  EXPECT_NEAR(d["uavs"][0]["x"][4].get<double>(), 100.0, 0.005);
  EXPECT_NEAR(d["uavs"][0]["x"][3].get<double>(), 90.0, 0.005);
}

TEST(ReportData, TerrainGridHoldsTheTerrainsHeightsOverTheArea) {
  const Fixture f = straight_flights();
  ReportOptions options;
  options.terrain_grid_points = 21;
  const nlohmann::json d = mission_report_data(f.input(), options);
  const nlohmann::json& g = d["terrain"];
  ASSERT_EQ(g["x"].size(), 21u);
  ASSERT_EQ(g["y"].size(), 21u);
  ASSERT_EQ(g["z"].size(), 21u);
  EXPECT_DOUBLE_EQ(g["x"][0].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(g["x"][20].get<double>(), 1000.0);
  EXPECT_DOUBLE_EQ(g["y"][20].get<double>(), 800.0);
  double highest = 0.0;
  for (std::size_t j = 0; j < 21; ++j) {
    ASSERT_EQ(g["z"][j].size(), 21u);
    for (std::size_t i = 0; i < 21; ++i) {
      const double z = g["z"][j][i];  // row j is y, column i is x; rounded to 0.1 m
      EXPECT_NEAR(z, f.terrain.height(g["x"][i], g["y"][j]), 0.05 + 1e-9);
      highest = std::max(highest, z);
    }
  }
  EXPECT_NEAR(highest, 150.0, 0.05);  // the peak at (400, 320) is a grid point
}

TEST(ReportData, TrackingErrorIsSampledEveryTenMetresOfFlownPath) {
  const Fixture f = straight_flights();
  const nlohmann::json d = mission_report_data(f.input());
  const nlohmann::json& e = d["uavs"][0]["error_by_distance"];
  // 100 m flown at 0.2 m per row: marks at 0, 10, ..., 100 m, each with the 1 m offset.
  ASSERT_EQ(e["distance_m"].size(), 11u);
  ASSERT_EQ(e["error_m"].size(), 11u);
  for (std::size_t k = 0; k < 11; ++k) {
    EXPECT_NEAR(e["distance_m"][k].get<double>(), 10.0 * static_cast<double>(k), 0.05);
    EXPECT_NEAR(e["error_m"][k].get<double>(), 1.0, 1e-3);
  }
  // A hovering UAV flies no distance: one sample at 0 m, its error 0.
  EXPECT_EQ(d["uavs"][1]["error_by_distance"]["distance_m"].size(), 1u);
}

TEST(ReportData, CarriesTargetsThreatsAndTheMetrics) {
  const Fixture f = straight_flights();
  const nlohmann::json d = mission_report_data(f.input());
  ASSERT_EQ(d["targets"].size(), 1u);
  EXPECT_EQ(d["targets"][0]["name"], "mast");
  ASSERT_EQ(d["threats"].size(), 1u);
  EXPECT_EQ(d["threats"][0]["radius_m"], 40.0);
  EXPECT_EQ(d["threats"][0]["appear_s"], 3.0);
  EXPECT_EQ(d["metrics"], mission::to_json(f.metrics));
}

TEST(ReportData, RowOfAnUnknownUavIsAnError) {
  Fixture f = straight_flights();
  f.rows[7].uav = 2;
  try {
    mission_report_data(f.input());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("UAV index 2"), std::string::npos) << e.what();
  }
}

// The JSON between <script type="application/json" id="report-data"> and its </script>.
nlohmann::json data_block(const std::string& html) {
  const std::string open = "<script type=\"application/json\" id=\"report-data\">";
  const std::size_t begin = html.find(open);
  EXPECT_NE(begin, std::string::npos);
  const std::size_t end = html.find("</script>", begin);
  return nlohmann::json::parse(html.substr(begin + open.size(), end - begin - open.size()));
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(ReportHtml, InlinesTheBundleTheDataAndTheMetricsTables) {
  const Fixture f = straight_flights();
  const std::string html = mission_report_html(f.input(), kFakePlotly);
  EXPECT_EQ(count(html, "BUNDLE-MARKER-7f3a"), 1u);
  EXPECT_EQ(data_block(html), mission_report_data(f.input()));
  for (const char* placeholder :
       {"{{TITLE}}", "{{PLOTLY_JS}}", "{{METRICS_TABLES}}", "{{REPORT_DATA}}"})
    EXPECT_EQ(html.find(placeholder), std::string::npos) << placeholder;
  // The six plots the page draws, and nothing loaded from elsewhere (it works offline).
  for (const char* id : {"plot-3d", "plot-top", "plot-length", "plot-mse", "plot-error",
                         "plot-avoidance", "time-slider", "report-status"})
    EXPECT_EQ(count(html, std::string("id=\"") + id + "\""), 1u) << id;
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  // Metrics tables: a row per UAV under its name, and the mission's values.
  EXPECT_NE(html.find("<td>alpha</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>bravo</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>avoidance_success_rate</td><td>1</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>mpc_solve_us.median</td>"), std::string::npos);
}

TEST(ReportHtml, NamesAndBundleCannotEndTheirScriptEarly) {
  Fixture f = straight_flights();
  const std::string evil = "</script><script>alert('x')</script><!--";
  f.scenario.name = evil;
  f.scenario.uavs[0].name = "a" + evil;
  f.metrics.uavs[0].name = "a" + evil;
  const std::string bundle =
      std::string(kFakePlotly) + " var s = '</script>', u = '</SCRIPT >', c = '<!--';";
  const std::string html = mission_report_html(f.input(), bundle);
  // Only the template's own script elements open and close: the error catcher, the bundle,
  // the data and the page's script.
  EXPECT_EQ(count(html, "<script"), 4u);
  EXPECT_EQ(count(html, "</script>"), 4u);
  EXPECT_EQ(count(html, "<!--"), 1u);  // the template's own comment
  // The data still reads back to the names as given.
  const nlohmann::json d = data_block(html);
  EXPECT_EQ(d["title"], evil);
  EXPECT_EQ(d["uavs"][0]["name"], "a" + evil);
  EXPECT_NE(html.find("&lt;/script&gt;"), std::string::npos);  // escaped in the title and table
}

TEST(ReportHtml, DefaultMissionSizedReportStaysSmallBesideTheBundle) {
  // 250 s of three UAVs at 50 Hz, as the default mission flies: the page without the bundle
  // must stay well under 1 MB (downsampled to 0.5 s, 10 m, a 60 x 60 grid).
  Fixture f = straight_flights();
  f.scenario.uavs.push_back(f.scenario.uavs[0]);
  f.scenario.uavs[2].name = "charlie";
  f.metrics.uavs.push_back(f.metrics.uavs[0]);
  f.rows.clear();
  for (int k = 0; k <= 12500; ++k)
    for (int i = 0; i < 3; ++i) {
      mission::TrajectoryRow r;
      r.t_s = 0.02 * k;
      r.uav = i;
      r.position_m = Vec3(7.123456 * r.t_s, 100.0 + 200.0 * i + std::sin(r.t_s), 80.5);
      r.reference_m = r.position_m + Vec3(0.3, -0.2, 0.1);
      f.rows.push_back(r);
    }
  const std::string html = mission_report_html(f.input(), kFakePlotly);
  EXPECT_LT(html.size(), 1'000'000u);
  EXPECT_EQ(data_block(html)["times"].size(), 501u);
}

// summary.json and runs.json shaped as `ridgeline montecarlo` writes them: three runs of two
// UAVs, the second run without a threat met (its threat distance null) and failed.
std::pair<nlohmann::json, nlohmann::json> monte_carlo_files() {
  nlohmann::json runs = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) {
    nlohmann::json run = {
        {"run", r},
        {"min_separation_m", 30.0 + r},
        {"min_threat_distance_m", r == 1 ? nlohmann::json() : nlohmann::json(40.0)},
        {"avoidance_success_rate", 1.0},
        {"sim_time_s", 200.0}};
    for (int u = 0; u < 2; ++u)
      run["uavs"].push_back({{"name", "u" + std::to_string(u)},
                             {"path_length_m", 1000.0 + 100.0 * r + u},
                             {"tracking_rmse_m", 0.5},
                             {"min_terrain_clearance_m", 21.0},
                             {"replans", 3}});
    runs.push_back(run);
  }
  const nlohmann::json summary = {
      {"scenario", "mc<b>"},
      {"counts", {{"safe_runs", 2}, {"complete_missions", 3}}},
      {"rates",
       {{"safe",
         {{"successes", 2}, {"trials", 3}, {"value", 2.0 / 3.0}, {"wilson95", {0.2, 0.94}}}}}},
      {"metrics",
       {{"path_length_m",
         {{"count", 6},
          {"min", 1000.0},
          {"median", 1100.0},
          {"mean", 1100.0},
          {"p90", 1200.0},
          {"max", 1201.0}}}}},
      {"failed_runs",
       {{{"run", 1},
         {"seed", 300002},
         {"reasons", {"terrain collision"}},
         {"replay", "ridgeline run --variation 300002"}}}}};
  return {summary, runs};
}

TEST(MonteCarloReport, DistributionsHoldAValuePerRunOrPerUavAndRunWithoutNulls) {
  const auto [summary, runs] = monte_carlo_files();
  const nlohmann::json d = montecarlo_report_data(summary, runs);
  EXPECT_EQ(d["title"], "mc<b>");
  EXPECT_EQ(d["runs"], 3);
  std::map<std::string, nlohmann::json> by_name;
  for (const nlohmann::json& series : d["distributions"]) by_name[series["name"]] = series;
  ASSERT_EQ(by_name.size(), 8u);
  EXPECT_EQ(by_name["min_separation_m"]["values"], nlohmann::json({30.0, 31.0, 32.0}));
  EXPECT_EQ(by_name["min_threat_distance_m"]["values"].size(), 2u);  // run 1's null left out
  EXPECT_EQ(by_name["path_length_m"]["scope"], "uav");
  EXPECT_EQ(by_name["path_length_m"]["values"],
            nlohmann::json({1000.0, 1001.0, 1100.0, 1101.0, 1200.0, 1201.0}));
  EXPECT_EQ(by_name["replans"]["values"].size(), 6u);
}

TEST(MonteCarloReport, PageInlinesTheBundleAndListsFailedRunsWithTheirReplay) {
  const auto [summary, runs] = monte_carlo_files();
  const std::string html = montecarlo_report_html(summary, runs, kFakePlotly);
  EXPECT_EQ(count(html, "BUNDLE-MARKER-7f3a"), 1u);
  EXPECT_EQ(data_block(html), montecarlo_report_data(summary, runs));
  EXPECT_NE(html.find("<code>ridgeline run --variation 300002</code>"), std::string::npos);
  EXPECT_NE(html.find("<td>terrain collision</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>path_length_m</td><td>6</td><td>1000</td><td>1100</td>"),
            std::string::npos);
  EXPECT_NE(html.find("Ridgeline Monte Carlo: mc&lt;b&gt;"), std::string::npos);
  EXPECT_EQ(html.find("{{"), std::string::npos);
}

TEST(MonteCarloReport, FilesOfTheWrongShapeAreAnError) {
  EXPECT_THROW(montecarlo_report_data(nlohmann::json::array(), nlohmann::json::array()),
               InputError);
  EXPECT_THROW(montecarlo_report_data(nlohmann::json::object(), nlohmann::json::object()),
               InputError);
}

TEST(PlotlyBundle, MissingFileIsAnErrorNamingItAndHowToInstallIt) {
  const std::filesystem::path missing = "/nonexistent/ridgeline/plotly.min.js";
  try {
    read_plotly_js(missing);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.field(), missing.string());
    EXPECT_NE(what.find("plotly.js not found"), std::string::npos) << what;
    EXPECT_NE(what.find("npm ci --prefix web"), std::string::npos) << what;
    EXPECT_NE(what.find("RIDGELINE_PLOTLY_JS"), std::string::npos) << what;
  }
}

TEST(PlotlyBundle, AFileThatIsNotPlotlyIsRejectedAndTheBundleIsReadWhole) {
  const std::filesystem::path dir = testing_support::fresh_test_dir();
  std::ofstream(dir / "empty.js") << "";
  std::ofstream(dir / "other.js") << "console.log('hello');";
  std::ofstream(dir / "plotly.min.js") << kFakePlotly;
  for (const char* name : {"empty.js", "other.js"}) {
    try {
      read_plotly_js(dir / name);
      ADD_FAILURE() << name << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("is not a plotly.js bundle"), std::string::npos)
          << e.what();
    }
  }
  EXPECT_EQ(read_plotly_js(dir / "plotly.min.js"), kFakePlotly);
  std::filesystem::remove_all(dir);
}

TEST(PlotlyBundle, EnvironmentVariableOverridesTheInstalledPath) {
  ASSERT_EQ(::setenv(kPlotlyJsEnvVar, "/somewhere/plotly.min.js", 1), 0);
  EXPECT_EQ(plotly_js_path(), std::filesystem::path("/somewhere/plotly.min.js"));
  ASSERT_EQ(::setenv(kPlotlyJsEnvVar, "", 1), 0);  // empty counts as unset
  const std::filesystem::path installed = std::filesystem::path(RIDGELINE_SOURCE_DIR) /
                                          "web/node_modules/plotly.js-dist-min/plotly.min.js";
  EXPECT_EQ(plotly_js_path(), installed);
  ASSERT_EQ(::unsetenv(kPlotlyJsEnvVar), 0);
  EXPECT_EQ(plotly_js_path(), installed);
}

}  // namespace
}  // namespace ridgeline::io
