// report.html in a real browser: `ridgeline run` flies a short mission and writes the report,
// and Debian's chromium, headless, loads it and dumps the page once its script has run. The
// page's status line (written by its own script, see web/report_template.html) must say that
// every plot was drawn — the 3-D view in WebGL included — and that no JavaScript error
// happened. A copy with an error planted in it must be caught, so the check can fail. Without
// plotly.js, `run` still writes its other outputs, warns once naming the missing file, and
// leaves no report.html behind. `ridgeline montecarlo`'s and `ridgeline experiment`'s reports
// are checked the same way.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;

// Two UAVs cross a hill toward two targets; a threat crosses their routes. 30 s of flight is
// enough to draw every figure (paths, a threat, tracking errors) and keeps the test short.
constexpr const char* kShortMission = R"yaml(
name: report-short
seed: 3
area: {x_min_m: 0, x_max_m: 800, y_min_m: 0, y_max_m: 800}
altitude: {min_m: 40, max_m: 400}
safety: {terrain_clearance_m: 20, separation_m: 10, threat_margin_m: 10}
terrain:
  combination: max
  base_elevation_m: 0
  peaks:
    - {x_m: 350, y_m: 300, height_m: 60, sigma_x_m: 120, sigma_y_m: 120}
uavs:
  - name: uav1
    start: {position_m: [100, 100, 60], heading_deg: 45, speed_m_s: 10}
  - name: uav2
    start: {position_m: [100, 150, 60], heading_deg: 45, speed_m_s: 10}
targets:
  - {name: a, position_m: [650, 550, 80]}
  - {name: b, position_m: [600, 650, 80]}
threats:
  - {name: t1, centre_m: [250, 450, 90], velocity_m_s: [2, -2, 0], radius_m: 30, appear_s: 5, vanish_s: 300}
planner: {waypoints_per_uav: 30}
simulation: {duration_s: 30}
)yaml";

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

int shell(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int run_cli(const std::string& env, const std::string& args, const fs::path& log) {
  return shell(env + " " + RIDGELINE_CLI_PATH + " " + args + " >" + log.string() +
               " 2>&1 </dev/null");
}

/// The browser: $RIDGELINE_CHROMIUM, else Debian's `chromium` (scripts/install-deps.sh --test).
std::string chromium() {
  const char* env = std::getenv("RIDGELINE_CHROMIUM");
  return env != nullptr && *env != '\0' ? env : "chromium";
}

/// Loads `page` headless and returns the text of its <pre id="report-status"> after the
/// page's script ran. --no-sandbox because CI runs as root; SwiftShader gives WebGL without a
/// GPU; the virtual time budget lets the page's promises settle before the DOM is dumped.
std::string browser_status(const fs::path& page, const fs::path& work) {
  const std::string probe = "command -v " + chromium() + " >/dev/null 2>&1";
  if (shell(probe) != 0) {
    ADD_FAILURE() << chromium()
                  << " not found: install Debian's chromium (scripts/install-deps.sh --test, "
                     "which make test runs) or set RIDGELINE_CHROMIUM";
    return "";
  }
  const fs::path dom = work / (page.stem().string() + ".dom.html");
  const fs::path log = work / (page.stem().string() + ".chromium.log");
  const std::string cmd = "timeout 120 " + chromium() +
                          " --headless --no-sandbox --disable-gpu --use-angle=swiftshader"
                          " --enable-unsafe-swiftshader --no-first-run --disable-extensions"
                          " --user-data-dir=" +
                          (work / "profile").string() +
                          " --virtual-time-budget=30000 --dump-dom file://" +
                          fs::absolute(page).string() + " >" + dom.string() + " 2>" + log.string();
  const int rc = shell(cmd);
  EXPECT_EQ(rc, 0) << cmd << "\n" << slurp(log);
  const std::string text = slurp(dom);
  std::smatch match;
  if (!std::regex_search(text, match, std::regex("<pre id=\"report-status\">([^<]*)</pre>"))) {
    ADD_FAILURE() << "no status line in the dumped page (" << text.size() << " bytes)\n"
                  << slurp(log);
    return "";
  }
  return match[1].str();
}

class ReportInBrowser : public ::testing::Test {
 protected:
  // One short mission for every test of the suite (flying it is most of the time).
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() /
                        ("ridgeline_report_browser_" + std::to_string(::getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
    std::ofstream(*dir_ / "short.yaml") << kShortMission;
    run_rc_ = run_cli("",
                      "run --quiet --scenario " + (*dir_ / "short.yaml").string() + " --out " +
                          (*dir_ / "out").string(),
                      *dir_ / "run.log");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static fs::path* dir_;
  static int run_rc_;
};
fs::path* ReportInBrowser::dir_ = nullptr;
int ReportInBrowser::run_rc_ = -1;

TEST_F(ReportInBrowser, RunWritesOneSelfContainedReport) {
  ASSERT_EQ(run_rc_, 0) << slurp(*dir_ / "run.log");
  const fs::path report = *dir_ / "out" / "report.html";
  ASSERT_TRUE(fs::exists(report)) << slurp(*dir_ / "run.log");
  const std::string html = slurp(report);
  // The minified bundle is ≈ 4.8 MB and inlined; the short mission's data adds little.
  EXPECT_GT(html.size(), 3'000'000u);
  EXPECT_LT(html.size(), 8'000'000u);
  EXPECT_NE(html.find("* plotly.js v"), std::string::npos);  // the bundle's licence header
  EXPECT_EQ(html.find("<script src="), std::string::npos);   // nothing fetched: works offline
  EXPECT_NE(html.find("\"name\":\"uav1\""), std::string::npos);
  EXPECT_NE(html.find("\"name\":\"uav2\""), std::string::npos);
  EXPECT_NE(html.find("\"name\":\"t1\""), std::string::npos);
  EXPECT_NE(slurp(*dir_ / "run.log").find("wrote report.html"), std::string::npos);
}

TEST_F(ReportInBrowser, EveryPlotRendersWithoutJavaScriptErrors) {
  ASSERT_EQ(run_rc_, 0) << slurp(*dir_ / "run.log");
  const std::string status = browser_status(*dir_ / "out" / "report.html", *dir_);
  EXPECT_EQ(status, "ok: 6 plots rendered");
}

TEST_F(ReportInBrowser, AJavaScriptErrorInThePageIsCaught) {
  ASSERT_EQ(run_rc_, 0) << slurp(*dir_ / "run.log");
  std::string html = slurp(*dir_ / "out" / "report.html");
  const std::size_t end = html.rfind("</body>");
  ASSERT_NE(end, std::string::npos);
  html.insert(end, "<script>ridgelineNoSuchFunction();</script>\n");
  const fs::path broken = *dir_ / "broken.html";
  std::ofstream(broken, std::ios::binary) << html;
  const std::string status = browser_status(broken, *dir_);
  EXPECT_EQ(status.rfind("error:", 0), 0u) << status;
  EXPECT_NE(status.find("ridgelineNoSuchFunction"), std::string::npos) << status;
}

TEST(MonteCarloReportInBrowser, RatesAndEveryDistributionRenderWithoutJavaScriptErrors) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  std::ofstream(dir / "short.yaml") << kShortMission;
  const int rc = run_cli("",
                         "montecarlo --quiet --runs 3 --threads 2 --scenario " +
                             (dir / "short.yaml").string() + " --out " + (dir / "mc").string(),
                         dir / "mc.log");
  // 30 s flights leave the missions incomplete, which montecarlo counts as failed runs (4).
  EXPECT_TRUE(rc == 0 || rc == 4) << rc << "\n" << slurp(dir / "mc.log");
  ASSERT_TRUE(fs::exists(dir / "mc" / "report.html")) << slurp(dir / "mc.log");
  // The rates chart and eight histograms.
  EXPECT_EQ(browser_status(dir / "mc" / "report.html", dir), "ok: 9 plots rendered");
  fs::remove_all(dir);
}

TEST(ExperimentReportInBrowser, FiguresThreeToFiveRenderWithoutJavaScriptErrors) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  std::ofstream(dir / "short.yaml") << kShortMission;
  const int rc = run_cli("",
                         "experiment --quiet --runs 1 --threads 2 --tasks northeast --scenario " +
                             (dir / "short.yaml").string() + " --out " + (dir / "ex").string(),
                         dir / "ex.log");
  EXPECT_EQ(rc, 0) << slurp(dir / "ex.log");
  ASSERT_TRUE(fs::exists(dir / "ex" / "report.html")) << slurp(dir / "ex.log");
  // Figures 3 and 4, the tracking MSE bars and one error-vs-distance chart for the one task,
  // each with a trace for every method, DDPG (the committed model) the fourth.
  EXPECT_EQ(browser_status(dir / "ex" / "report.html", dir),
            "ok: 4 plots rendered, each with methods proposed,astar_dwa,wind_aware,ddpg");
  fs::remove_all(dir);
}

TEST(RunWithoutPlotly, OtherOutputsAreWrittenWithOneWarningAndNoReport) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  std::ofstream(dir / "short.yaml") << kShortMission;
  const fs::path out = dir / "out";
  fs::create_directories(out);
  std::ofstream(out / "report.html") << "a report of an earlier run";
  const fs::path missing = dir / "no-such-folder" / "plotly.min.js";
  const int rc =
      run_cli("RIDGELINE_PLOTLY_JS=" + missing.string(),
              "run --quiet --scenario " + (dir / "short.yaml").string() + " --out " + out.string(),
              dir / "run.log");
  const std::string log = slurp(dir / "run.log");
  EXPECT_EQ(rc, 0) << log;
  for (const char* file : {"metrics.json", "trajectories.csv", "plan.json", "summary.json"})
    EXPECT_TRUE(fs::exists(out / file)) << file;
  EXPECT_FALSE(fs::exists(out / "report.html"));  // the stale one is gone, no new one
  const std::string warning = "warning: no report.html: " + missing.string() +
                              ": plotly.js not found; install it with `npm ci --prefix web`";
  EXPECT_NE(log.find(warning), std::string::npos) << log;
  EXPECT_EQ(log.find("warning", log.find("warning") + 1), std::string::npos) << log;  // once
  fs::remove_all(dir);
}

}  // namespace
