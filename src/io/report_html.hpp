// DIR/report.html: one self-contained page a person opens offline to see a flown mission —
// the paper's figures (DESIGN §6) drawn with plotly.js, which is inlined into the page.
//
// What the page shows:
//   * Figure 2: the terrain as a 3-D surface (sampled on a grid from the run's world::Terrain),
//     every UAV's reference (dashed) and flown path, the targets and the threat spheres, with a
//     time slider that moves the UAV markers and the threats (eq. 13: c(t) = c0 + v_T·(t − t0));
//   * a 2-D top view: terrain contours, paths, targets, threat tracks and the threats' discs at
//     the slider's time;
//   * per UAV the path length (Figure 3's shape) and the tracking MSE, the tracking error
//     against the distance flown (Figure 5's shape), and the threat avoidance success;
//   * the metrics table (every field of metrics.json).
//
// The page is built from a template (web/report_template.html, embedded at build time) with
// the data as one JSON block. Trajectories are downsampled (every 0.5 s by default) so the
// page is the plotly bundle (≈ 4.8 MB) plus a few hundred kB at most.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "mission/mission_metrics.hpp"
#include "mission/scenario.hpp"
#include "world/terrain.hpp"

namespace ridgeline::io {

struct ReportOptions {
  /// Period (s) at which trajectories are sampled for the paths and the time slider.
  double sample_period_s = 0.5;
  /// Terrain grid points per side of the scenario's area (the surface and the contours).
  int terrain_grid_points = 60;
  /// Flown distance (m) between two points of the tracking-error-vs-distance chart; the
  /// metrics' tracking MSE is sampled at the same 10 m.
  double error_sample_spacing_m = 10.0;
};

/// What a report is made of. `trajectories` are the rows of trajectories.csv (any order;
/// `uav` indexes scenario.uavs).
struct MissionReportInput {
  const mission::Scenario& scenario;
  const world::Terrain& terrain;
  const mission::MissionMetrics& metrics;
  const std::vector<mission::TrajectoryRow>& trajectories;
};

/// The report's data block (what the page's script draws): {"title", "area", "terrain": {x, y,
/// z[row y][col x]}, "times", "uavs": [{name, start, x, y, z, ref_x, ref_y, ref_z (one value per
/// time), error_by_distance: {distance_m, error_m}}], "targets", "threats", "metrics"}.
/// Lengths in metres, times in seconds, rounded to 1 cm and 10 ms. Throws InputError for a
/// row whose UAV index is not in the scenario or for options out of range.
nlohmann::json mission_report_data(const MissionReportInput& input,
                                   const ReportOptions& options = {});

/// The whole page with `plotly_js` (the contents of plotly.min.js) inlined. The page's script
/// writes its state into `<pre id="report-status">`: "ok: N plots rendered" once every plot is
/// drawn, or "error: ..." listing every JavaScript error (the browser test reads it).
std::string mission_report_html(const MissionReportInput& input, std::string_view plotly_js,
                                const ReportOptions& options = {});

/// The data block of `ridgeline montecarlo`'s report: {"title", "runs", "summary" (as given),
/// "distributions": [{name, scope ("mission": one value per run, "uav": one per UAV and run),
/// unit, values}]}. `summary` and `runs` are summary.json and runs.json as montecarlo writes
/// them; a value that is null (e.g. no threat met) is left out of its distribution.
nlohmann::json montecarlo_report_data(const nlohmann::json& summary, const nlohmann::json& runs);

/// DIR/report.html of `ridgeline montecarlo`: the rates with their Wilson 95 % intervals, a
/// histogram of each distribution, the counts, the summary's percentiles and the failed runs
/// with the commands that replay them. Same status line as mission_report_html.
std::string montecarlo_report_html(const nlohmann::json& summary, const nlohmann::json& runs,
                                   std::string_view plotly_js);

/// DIR/report.html of `ridgeline experiment` (sim/experiment.hpp's experiment.json as given):
/// Figure 3 (path length per task and method, mean ± std), Figure 4 (avoidance success with
/// the encounters), Figure 5 (tracking MSE per task and method, and against the distance flown
/// per task), and a table per task. Same status line as mission_report_html. Throws
/// InputError when a top-level field is missing.
std::string experiment_report_html(const nlohmann::json& experiment, std::string_view plotly_js);

/// The environment variable that overrides where plotly.min.js is read from.
inline constexpr const char* kPlotlyJsEnvVar = "RIDGELINE_PLOTLY_JS";

/// Where plotly.min.js is read from: $RIDGELINE_PLOTLY_JS when set and not empty, else the
/// path compiled in by CMake: web/node_modules/plotly.js-dist-min/plotly.min.js of the source
/// tree, which `make run` and `make test` install with `npm ci --prefix web`.
std::filesystem::path plotly_js_path();

/// Reads the plotly bundle. Throws InputError naming the file and how to install it when it
/// is missing or unreadable, or when it does not look like plotly.js.
std::string read_plotly_js(const std::filesystem::path& path);

}  // namespace ridgeline::io
