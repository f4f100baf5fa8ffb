// `ridgeline export --plan DIR/plan.json --format qgc|geojson|kml|csv --out FILE`: the plan in
// geographic coordinates for QGroundControl, GIS tools and Google Earth (io/geo_export.hpp).
// The plan's geodetic origin places it on the Earth; a plan without one needs --origin.
// A QGroundControl .plan holds one vehicle's mission, so a team gives one file per UAV,
// FILE's name with "-<uav>" before the extension (or only FILE for --uav ID).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "apps/commands.hpp"
#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "io/geo_export.hpp"
#include "io/geo_frame.hpp"

namespace ridgeline::apps {

namespace {

namespace fs = std::filesystem;

struct ExportArgs {
  std::string plan;
  std::string format;
  std::string out;
  std::string origin;
  std::string uav;
};

nlohmann::json read_plan(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot read the plan file");
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path, std::string("is not valid JSON: ") + e.what());
  }
}

void run_export(const ExportArgs& args) {
  if (args.format != "qgc" && args.format != "geojson" && args.format != "kml" &&
      args.format != "csv") {
    throw InputError("--format", "must be qgc, geojson, kml or csv, got '" + args.format + "'");
  }
  std::optional<mission::GeodeticOrigin> origin;
  if (!args.origin.empty()) origin = io::parse_origin_text(args.origin, "--origin");
  const io::MissionGeometry mission =
      io::mission_from_plan_json(read_plan(args.plan), args.plan, origin);
  const fs::path out(args.out);
  if (args.format == "geojson") {
    io::write_file_atomically(out, io::to_geojson(mission));
  } else if (args.format == "kml") {
    io::write_file_atomically(out, io::to_kml(mission));
  } else if (args.format == "csv") {
    io::write_file_atomically(out, io::to_csv(mission));
  }
  if (args.format != "qgc") {
    std::cout << "wrote " << out.string() << '\n';
    return;
  }
  // Every file is made before any is written, so a bad --uav writes nothing.
  std::vector<std::pair<fs::path, std::string>> files;
  for (std::size_t i = 0; i < mission.paths.size(); ++i) {
    const std::string& name = mission.paths[i].name;
    if (!args.uav.empty() && name != args.uav) continue;
    fs::path file = out;
    if (args.uav.empty() && mission.paths.size() > 1) {
      file = out.parent_path() / (out.stem().string() + "-" + name +
                                  (out.has_extension() ? out.extension().string() : ".plan"));
    }
    files.emplace_back(file, io::to_qgc_plan(mission, i).dump(2) + "\n");
  }
  if (files.empty()) {
    std::string names;
    for (const io::ExportPath& p : mission.paths) names += (names.empty() ? "" : ", ") + p.name;
    throw InputError("--uav", "no UAV '" + args.uav + "' in the plan (it has " + names + ")");
  }
  for (const auto& [file, text] : files) {
    io::write_file_atomically(file, text);
    std::cout << "wrote " << file.string() << '\n';
  }
}

}  // namespace

void register_export_command(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "export", "Export a plan in WGS 84: QGroundControl .plan, GeoJSON, KML or CSV");
  cmd->add_option("--plan", args->plan, "plan.json written by `ridgeline plan` or `run`")
      ->required();
  cmd->add_option("--format", args->format, "qgc | geojson | kml | csv")->required();
  cmd->add_option("--out", args->out,
                  "output file (qgc with several UAVs: one file per UAV, named FILE-<uav>.plan)")
      ->required();
  cmd->add_option("--origin", args->origin,
                  "LAT,LON,ALT_AMSL: the geodetic origin of a plan whose scenario named none "
                  "(the plan's local (0, 0) and the frame of io/geo_frame.hpp)");
  cmd->add_option("--uav", args->uav, "qgc: only this UAV, written to FILE itself");
  cmd->callback([args] { run_export(*args); });
}

}  // namespace ridgeline::apps
