#include "io/report_html.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "io/markup_escape.hpp"

namespace ridgeline::io {

extern const char* const kReportTemplateHtml;      // generated from web/report_template.html
extern const char* const kMonteCarloTemplateHtml;  // from web/montecarlo_template.html
extern const char* const kExperimentTemplateHtml;  // from web/experiment_template.html

namespace {

constexpr const char* kInstallHint =
    "install it with `npm ci --prefix web` in the source folder (make run and make test do), "
    "or point RIDGELINE_PLOTLY_JS at a plotly.min.js";

/// Rounds to a multiple of `quantum` so the JSON carries only meaningful digits (nlohmann
/// prints the shortest decimal that reads back to the same double).
double rounded(double value, double quantum) { return std::round(value / quantum) * quantum; }

nlohmann::json metres(double v) { return rounded(v, 0.01); }
nlohmann::json point(const Vec3& p) { return {metres(p.x()), metres(p.y()), metres(p.z())}; }

/// Text inside <script> ends at the first "</script" (in any case) whatever the JavaScript
/// around it means, and "<!--" changes how the HTML parser looks for that end. Writing the '<'
/// of both as \x3C (the same character inside a JavaScript string or regular expression, the
/// only places minified code has them) keeps the script's meaning and its end where it belongs.
std::string script_safe_js(std::string_view js) {
  auto starts_with_ci = [&js](std::size_t at, std::string_view word) {
    if (js.size() - at < word.size()) return false;
    for (std::size_t k = 0; k < word.size(); ++k)
      if (std::tolower(static_cast<unsigned char>(js[at + k])) != word[k]) return false;
    return true;
  };
  std::string out;
  out.reserve(js.size());
  for (std::size_t at = 0; at < js.size(); ++at) {
    if (js[at] == '<' && (starts_with_ci(at + 1, "/script") || starts_with_ci(at + 1, "!--")))
      out += "\\x3C";
    else
      out += js[at];
  }
  return out;
}

/// In JSON a '<' can only stand inside a string, where \u003c is the same character.
std::string script_safe_json(const nlohmann::json& data) {
  const std::string json = data.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string out;
  out.reserve(json.size());
  for (char c : json) {
    if (c == '<')
      out += "\\u003c";
    else
      out += c;
  }
  return out;
}

/// One cell of the metrics table: integers as they are, other numbers with four significant
/// digits (whole metres and microseconds above 1000), null as "–".
std::string cell(const nlohmann::json& v) {
  if (v.is_null()) return "–";
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number_float()) {
    const double d = v.get<double>();
    return std::abs(d) >= 1000.0 ? fmt::format("{:.0f}", d) : fmt::format("{:.4g}", d);
  }
  if (v.is_string()) return escape_markup(v.get<std::string>());
  if (v.is_array()) {
    std::string out;
    for (const nlohmann::json& e : v) out += (out.empty() ? "" : ", ") + cell(e);
    return out.empty() ? "–" : out;
  }
  return escape_markup(v.dump());
}

/// Every field of metrics.json: a table with a row per UAV and one of the mission's values
/// (objects flattened to `name.key`).
std::string metrics_tables(const nlohmann::json& metrics) {
  std::string html = "<table id=\"metrics-uavs\">\n<tr>";
  const nlohmann::json& uavs = metrics.at("uavs");
  std::vector<std::string> columns = {"name"};  // then the rest in metrics.json's order
  if (!uavs.empty())
    for (const auto& [key, value] : uavs.front().items())
      if (key != "name") columns.push_back(key);
  for (const std::string& c : columns) html += "<th>" + escape_markup(c) + "</th>";
  html += "</tr>\n";
  for (const nlohmann::json& u : uavs) {
    html += "<tr>";
    for (const std::string& c : columns)
      html += "<td>" + cell(u.value(c, nlohmann::json())) + "</td>";
    html += "</tr>\n";
  }
  html += "</table>\n<table id=\"metrics-mission\">\n<tr><th>metric</th><th>value</th></tr>\n";
  for (const auto& [key, value] : metrics.items()) {
    if (key == "uavs") continue;
    if (value.is_object()) {
      for (const auto& [sub, v] : value.items())
        html +=
            "<tr><td>" + escape_markup(key + "." + sub) + "</td><td>" + cell(v) + "</td></tr>\n";
      if (value.empty()) html += "<tr><td>" + escape_markup(key) + "</td><td>none</td></tr>\n";
    } else {
      html += "<tr><td>" + escape_markup(key) + "</td><td>" + cell(value) + "</td></tr>\n";
    }
  }
  return html + "</table>";
}

/// Fills every occurrence of the template's placeholders in one pass over the template, so
/// text put in (the plotly bundle above all) is never searched for placeholders itself.
std::string fill_template(std::string_view tmpl,
                          const std::vector<std::pair<std::string_view, std::string_view>>& fills) {
  std::vector<std::pair<std::size_t, std::size_t>> at;  // (position in template, fill index)
  for (std::size_t k = 0; k < fills.size(); ++k) {
    const std::size_t first = tmpl.find(fills[k].first);
    if (first == std::string_view::npos)
      throw std::logic_error(fmt::format("report template: no placeholder {}", fills[k].first));
    for (std::size_t pos = first; pos != std::string_view::npos;
         pos = tmpl.find(fills[k].first, pos + 1))
      at.emplace_back(pos, k);
  }
  std::sort(at.begin(), at.end());
  std::string out;
  std::size_t size = tmpl.size();
  for (const auto& [pos, k] : at) size += fills[k].second.size();
  out.reserve(size);
  std::size_t from = 0;
  for (const auto& [pos, k] : at) {
    out.append(tmpl.substr(from, pos - from));
    out.append(fills[k].second);
    from = pos + fills[k].first.size();
  }
  out.append(tmpl.substr(from));
  return out;
}

}  // namespace

nlohmann::json mission_report_data(const MissionReportInput& input, const ReportOptions& options) {
  if (!(options.sample_period_s > 0.0) || !std::isfinite(options.sample_period_s))
    throw InputError(
        "report.sample_period_s",
        fmt::format("{} must be a positive number of seconds", options.sample_period_s));
  if (options.terrain_grid_points < 2 || options.terrain_grid_points > 1000)
    throw InputError("report.terrain_grid_points",
                     fmt::format("{} must be in [2, 1000]", options.terrain_grid_points));
  if (!(options.error_sample_spacing_m > 0.0) || !std::isfinite(options.error_sample_spacing_m))
    throw InputError(
        "report.error_sample_spacing_m",
        fmt::format("{} must be a positive number of metres", options.error_sample_spacing_m));
  const mission::Scenario& s = input.scenario;

  // Rows per UAV in time order.
  std::vector<std::vector<const mission::TrajectoryRow*>> rows(s.uavs.size());
  double t_end = 0.0;
  for (const mission::TrajectoryRow& r : input.trajectories) {
    if (r.uav < 0 || static_cast<std::size_t>(r.uav) >= s.uavs.size())
      throw InputError("trajectories", fmt::format("a row at t = {} s names UAV index {}, but the "
                                                   "scenario has {} UAVs",
                                                   r.t_s, r.uav, s.uavs.size()));
    rows[static_cast<std::size_t>(r.uav)].push_back(&r);
    t_end = std::max(t_end, r.t_s);
  }
  for (auto& list : rows)
    std::stable_sort(list.begin(), list.end(),
                     [](const mission::TrajectoryRow* a, const mission::TrajectoryRow* b) {
                       return a->t_s < b->t_s;
                     });

  // The slider's times: every sample period, and the last row's time so the end is shown.
  std::vector<double> times;
  if (!input.trajectories.empty()) {
    const auto n = static_cast<long long>(std::floor(t_end / options.sample_period_s + 1e-9));
    for (long long k = 0; k <= n; ++k)
      times.push_back(static_cast<double>(k) * options.sample_period_s);
    if (times.back() < t_end - 1e-9) times.push_back(t_end);
  }

  nlohmann::json uavs = nlohmann::json::array();
  for (std::size_t i = 0; i < s.uavs.size(); ++i) {
    const std::vector<const mission::TrajectoryRow*>& list = rows[i];
    std::array<nlohmann::json, 6> columns;  // x, y, z, ref_x, ref_y, ref_z at each time
    for (auto& c : columns) c = nlohmann::json::array();
    std::size_t next = 0;  // the UAV's state at time t is its last row at or before t
    for (const double t : times) {
      if (list.empty()) break;
      while (next + 1 < list.size() && list[next + 1]->t_s <= t + 1e-9) ++next;
      const mission::TrajectoryRow& r = *list[next];
      for (int a = 0; a < 3; ++a) {
        columns[static_cast<std::size_t>(a)].push_back(metres(r.position_m[a]));
        columns[static_cast<std::size_t>(a + 3)].push_back(metres(r.reference_m[a]));
      }
    }
    // |p − r| every error_sample_spacing_m of flown path, from the full-rate rows.
    nlohmann::json distance = nlohmann::json::array(), error = nlohmann::json::array();
    double flown_m = 0.0, next_mark_m = 0.0;
    for (std::size_t k = 0; k < list.size(); ++k) {
      if (k > 0) flown_m += (list[k]->position_m - list[k - 1]->position_m).norm();
      if (flown_m + 1e-9 >= next_mark_m) {
        distance.push_back(rounded(flown_m, 0.1));
        error.push_back(rounded((list[k]->position_m - list[k]->reference_m).norm(), 0.001));
        next_mark_m = (std::floor(flown_m / options.error_sample_spacing_m) + 1.0) *
                      options.error_sample_spacing_m;
      }
    }
    uavs.push_back({{"name", s.uavs[i].name},
                    {"start_m", point(s.uavs[i].start_position_m)},
                    {"x", columns[0]},
                    {"y", columns[1]},
                    {"z", columns[2]},
                    {"ref_x", columns[3]},
                    {"ref_y", columns[4]},
                    {"ref_z", columns[5]},
                    {"error_by_distance", {{"distance_m", distance}, {"error_m", error}}}});
  }

  const int n = options.terrain_grid_points;
  nlohmann::json gx = nlohmann::json::array(), gy = nlohmann::json::array(),
                 gz = nlohmann::json::array();
  auto grid = [n](double lo, double hi, int k) {
    return lo + (hi - lo) * static_cast<double>(k) / static_cast<double>(n - 1);
  };
  for (int k = 0; k < n; ++k) {
    gx.push_back(rounded(grid(s.area.x_min_m, s.area.x_max_m, k), 0.01));
    gy.push_back(rounded(grid(s.area.y_min_m, s.area.y_max_m, k), 0.01));
  }
  for (int j = 0; j < n; ++j) {
    nlohmann::json row = nlohmann::json::array();
    const double y = grid(s.area.y_min_m, s.area.y_max_m, j);
    for (int k = 0; k < n; ++k)
      row.push_back(rounded(input.terrain.height(grid(s.area.x_min_m, s.area.x_max_m, k), y), 0.1));
    gz.push_back(std::move(row));
  }

  nlohmann::json targets = nlohmann::json::array();
  for (const mission::InspectionTarget& t : s.targets)
    targets.push_back({{"name", t.name},
                       {"position_m", point(t.position_m)},
                       {"inspection_radius_m", t.inspection_radius_m}});
  nlohmann::json threats = nlohmann::json::array();
  for (const world::Threat& th : s.threats)
    threats.push_back(
        {{"name", th.name},
         {"centre_m", point(th.centre_m)},
         {"velocity_m_s", {th.velocity_m_s.x(), th.velocity_m_s.y(), th.velocity_m_s.z()}},
         {"radius_m", th.radius_m},
         {"appear_s", th.appear_s},
         {"vanish_s", th.vanish_s}});

  nlohmann::json time_json = nlohmann::json::array();
  for (const double t : times) time_json.push_back(rounded(t, 0.01));
  return {{"title", s.name},
          {"area",
           {{"x_min_m", s.area.x_min_m},
            {"x_max_m", s.area.x_max_m},
            {"y_min_m", s.area.y_min_m},
            {"y_max_m", s.area.y_max_m}}},
          {"terrain", {{"x", gx}, {"y", gy}, {"z", gz}}},
          {"times", time_json},
          {"uavs", uavs},
          {"targets", targets},
          {"threats", threats},
          {"metrics", mission::to_json(input.metrics)}};
}

std::string mission_report_html(const MissionReportInput& input, std::string_view plotly_js,
                                const ReportOptions& options) {
  const nlohmann::json data = mission_report_data(input, options);
  const std::string title = escape_markup(input.scenario.name);
  const std::string tables = metrics_tables(data.at("metrics"));
  const std::string js = script_safe_js(plotly_js);
  const std::string json = script_safe_json(data);
  return fill_template(kReportTemplateHtml, {{"{{TITLE}}", title},
                                             {"{{PLOTLY_JS}}", js},
                                             {"{{METRICS_TABLES}}", tables},
                                             {"{{REPORT_DATA}}", json}});
}

nlohmann::json montecarlo_report_data(const nlohmann::json& summary, const nlohmann::json& runs) {
  if (!summary.is_object() || !runs.is_array())
    throw InputError("montecarlo report", "needs summary.json's object and runs.json's array");
  struct Series {
    const char* name;
    const char* scope;
    const char* unit;
  };
  static constexpr std::array<Series, 8> kSeries{{
      {"min_separation_m", "mission", "m"},
      {"min_threat_distance_m", "mission", "m"},
      {"avoidance_success_rate", "mission", "fraction"},
      {"sim_time_s", "mission", "s"},
      {"path_length_m", "uav", "m"},
      {"tracking_rmse_m", "uav", "m"},
      {"min_terrain_clearance_m", "uav", "m"},
      {"replans", "uav", "re-plans"},
  }};
  nlohmann::json distributions = nlohmann::json::array();
  for (const Series& series : kSeries) {
    nlohmann::json values = nlohmann::json::array();
    auto add = [&values, &series](const nlohmann::json& object) {
      const auto it = object.find(series.name);
      if (it != object.end() && it->is_number()) values.push_back(rounded(it->get<double>(), 1e-4));
    };
    for (const nlohmann::json& run : runs) {
      if (std::string_view(series.scope) == "mission") {
        add(run);
      } else if (const auto u = run.find("uavs"); u != run.end() && u->is_array()) {
        for (const nlohmann::json& uav : *u) add(uav);
      }
    }
    distributions.push_back({{"name", series.name},
                             {"scope", series.scope},
                             {"unit", series.unit},
                             {"values", values}});
  }
  return {{"title", summary.value("scenario", std::string("unnamed"))},
          {"runs", runs.size()},
          {"summary", summary},
          {"distributions", distributions}};
}

namespace {

/// Counts, the summary's percentiles per metric and the failed runs with their replays.
std::string montecarlo_tables(const nlohmann::json& summary) {
  std::string html = "<table id=\"mc-counts\">\n<tr><th>count</th><th>value</th></tr>\n";
  const nlohmann::json counts = summary.value("counts", nlohmann::json::object());
  const nlohmann::json metrics = summary.value("metrics", nlohmann::json::object());
  for (const auto& [key, value] : counts.items())
    html += "<tr><td>" + escape_markup(key) + "</td><td>" + cell(value) + "</td></tr>\n";
  html += "</table>\n<table id=\"mc-metrics\">\n<tr><th>metric</th>";
  const std::array<const char*, 6> stats{"count", "min", "median", "mean", "p90", "max"};
  for (const char* stat : stats) html += fmt::format("<th>{}</th>", stat);
  html += "</tr>\n";
  for (const auto& [key, value] : metrics.items()) {
    html += "<tr><td>" + escape_markup(key) + "</td>";
    for (const char* stat : stats)
      html += "<td>" + cell(value.value(stat, nlohmann::json())) + "</td>";
    html += "</tr>\n";
  }
  html +=
      "</table>\n<table id=\"mc-failed\">\n<tr><th>run</th><th>seed</th><th>reasons</th>"
      "<th>replay</th></tr>\n";
  const nlohmann::json failed = summary.value("failed_runs", nlohmann::json::array());
  for (const nlohmann::json& f : failed)
    html += "<tr><td>" + cell(f.value("run", nlohmann::json())) + "</td><td>" +
            cell(f.value("seed", nlohmann::json())) + "</td><td>" +
            cell(f.value("reasons", nlohmann::json())) + "</td><td><code>" +
            cell(f.value("replay", nlohmann::json())) + "</code></td></tr>\n";
  if (failed.empty()) html += "<tr><td colspan=\"4\">none</td></tr>\n";
  return html + "</table>";
}

}  // namespace

std::string montecarlo_report_html(const nlohmann::json& summary, const nlohmann::json& runs,
                                   std::string_view plotly_js) {
  const nlohmann::json data = montecarlo_report_data(summary, runs);
  const std::string title = escape_markup(data.at("title").get<std::string>());
  const std::string tables = montecarlo_tables(summary);
  const std::string js = script_safe_js(plotly_js);
  const std::string json = script_safe_json(data);
  return fill_template(kMonteCarloTemplateHtml, {{"{{TITLE}}", title},
                                                 {"{{PLOTLY_JS}}", js},
                                                 {"{{METRICS_TABLES}}", tables},
                                                 {"{{REPORT_DATA}}", json}});
}

namespace {

/// One table per task: a row per method with the figures' values and the counts.
std::string experiment_tables(const nlohmann::json& e) {
  std::string html;
  const auto num = [](const nlohmann::json& v) { return cell(v); };
  for (const nlohmann::json& task : e.at("tasks")) {
    html += "<h3>task " + escape_markup(task.at("task").get<std::string>()) + " — " +
            escape_markup(task.value("description", "")) + "</h3>\n";
    html +=
        "<table class=\"experiment-task\">\n<tr><th>method</th><th>plan</th><th>plan time s</th>"
        "<th>path m mean</th><th>path m std</th><th>avoidance success</th><th>encounters</th>"
        "<th>tracking MSE m² mean</th><th>std</th><th>terrain coll.</th><th>threat intr.</th>"
        "<th>separation viol.</th><th>constraint viol.</th><th>complete</th>"
        "<th>step µs median</th><th>p99</th><th>max</th></tr>\n";
    for (const auto& [name, M] : task.at("methods").items()) {
      html += "<tr><td>" + escape_markup(name) + "</td><td>" + num(M.at("plan_status")) +
              "</td><td>" + num(M.at("plan_time_s")) + "</td><td>" +
              num(M.at("path_length_m").at("mean")) + "</td><td>" +
              num(M.at("path_length_m").at("std")) + "</td><td>" +
              num(M.at("avoidance_success_rate")) + "</td><td>" + num(M.at("threat_encounters")) +
              "</td><td>" + num(M.at("tracking_mse_m2").at("mean")) + "</td><td>" +
              num(M.at("tracking_mse_m2").at("std")) + "</td><td>" +
              num(M.at("collisions").at("terrain")) + "</td><td>" +
              num(M.at("collisions").at("threat")) + "</td><td>" +
              num(M.at("collisions").at("separation")) + "</td><td>" +
              num(M.at("constraint_violations")) + "</td><td>" + num(M.at("missions_complete")) +
              " / " + num(M.at("flown_runs")) + "</td><td>" +
              num(M.at("control_step_us").at("median")) + "</td><td>" +
              num(M.at("control_step_us").at("p99")) + "</td><td>" +
              num(M.at("control_step_us").at("max")) + "</td></tr>\n";
    }
    html += "</table>\n";
  }
  return html;
}

}  // namespace

std::string experiment_report_html(const nlohmann::json& experiment, std::string_view plotly_js) {
  for (const char* key : {"tasks", "methods", "runs", "threads", "wall_time_s"})
    if (!experiment.contains(key)) throw InputError(std::string("experiment.") + key, "is missing");
  const std::string title =
      fmt::format("{} tasks x {} methods x {} runs", experiment["tasks"].size(),
                  experiment["methods"].size(), experiment["runs"].dump());
  const std::string tables = experiment_tables(experiment);
  const std::string js = script_safe_js(plotly_js);
  const std::string json = script_safe_json(experiment);
  return fill_template(kExperimentTemplateHtml, {{"{{TITLE}}", escape_markup(title)},
                                                 {"{{PLOTLY_JS}}", js},
                                                 {"{{METRICS_TABLES}}", tables},
                                                 {"{{REPORT_DATA}}", json}});
}

std::filesystem::path plotly_js_path() {
  if (const char* env = std::getenv(kPlotlyJsEnvVar); env != nullptr && *env != '\0')
    return std::filesystem::path(env);
  return std::filesystem::path(RIDGELINE_PLOTLY_JS_DEFAULT);
}

std::string read_plotly_js(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path.string(), fmt::format("plotly.js not found; {}", kInstallHint));
  std::ifstream in(path, std::ios::binary);
  std::string js((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof())
    throw InputError(path.string(), fmt::format("plotly.js could not be read; {}", kInstallHint));
  // The bundle's licence header names it; anything else (an empty or truncated download, a
  // wrong file) would give a page whose plots silently never appear.
  if (js.find("plotly.js") == std::string::npos || js.find("newPlot") == std::string::npos)
    throw InputError(path.string(),
                     fmt::format("is not a plotly.js bundle (no 'plotly.js' header or newPlot); {}",
                                 kInstallHint));
  return js;
}

}  // namespace ridgeline::io
