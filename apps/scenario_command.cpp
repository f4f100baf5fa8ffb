// `ridgeline scenario default`: prints the embedded default scenario as commented YAML.
// `ridgeline scenario team --uavs N --targets M --seed S [--threats K] [--dem FILE] [--out FILE]`:
// a team scenario (mission/team_scenario.hpp) on the default terrain or a DEM, checked by the
// scenario loader before it is printed or written; bad input is one error naming the option.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <iostream>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "io/dem_file.hpp"
#include "io/scenario_file.hpp"
#include "io/team_scenario_file.hpp"
#include "mission/team_scenario.hpp"

namespace ridgeline::apps {
namespace {

struct TeamArgs {
  std::string uavs;
  std::string targets;
  std::string seed = "1";
  std::string threats;
  std::string dem;
  std::string out;
};

// The options are read as text so that "nan", "1.5" or "-3" is one error naming the option
// (exit 2), not CLI11's conversion error.
long long parse_integer(const std::string& option, const std::string& text, long long min) {
  const std::optional<long long> value = whole_integer(text);
  if (!value) throw InputError(option, fmt::format("must be an integer, got '{}'", text));
  if (*value < min) throw InputError(option, fmt::format("must be >= {}, got {}", min, *value));
  return *value;
}

void write_team_scenario(const TeamArgs& args, const std::string& how_made) {
  constexpr long long kMaxCount = 100000;
  mission::TeamScenarioOptions options;
  options.uavs = static_cast<int>(std::min(parse_integer("--uavs", args.uavs, 1), kMaxCount));
  options.targets =
      static_cast<int>(std::min(parse_integer("--targets", args.targets, 1), kMaxCount));
  options.seed = static_cast<std::uint64_t>(parse_integer("--seed", args.seed, 0));
  if (!args.threats.empty())
    options.threats =
        static_cast<int>(std::min(parse_integer("--threats", args.threats, 0), kMaxCount));

  io::LoadedScenario base = io::load_default_scenario();
  std::string dem_path;
  if (!args.dem.empty()) {
    // The DEM's own frame (no origin): the area is its extent, half a cell inside.
    std::error_code ec;
    dem_path = std::filesystem::absolute(args.dem, ec).lexically_normal().string();
    if (!std::filesystem::is_regular_file(dem_path))
      throw InputError("--dem", fmt::format("'{}' is not a readable file", args.dem));
    world::RasterGrid grid;
    try {
      grid = io::load_dem_local(dem_path);
    } catch (const InputError& e) {
      throw InputError("--dem", e.what());
    }
    mission::Scenario& s = base.scenario;
    s.area = {grid.origin_x_m, grid.x_of_col(grid.cols - 1), grid.origin_y_m,
              grid.y_of_row(grid.rows - 1)};
    s.terrain.kind = mission::TerrainSource::Kind::kDem;
    s.terrain.dem_path = dem_path;
    s.terrain.dem_model = mission::TerrainSource::DemModel::kRaster;
    try {
      base.terrain = io::build_terrain(s.terrain, s.origin, s.area);
    } catch (const InputError& e) {
      throw InputError("--dem", e.what());
    }
  }
  mission::Scenario team;
  try {
    team = mission::make_team_scenario(base.scenario, *base.terrain, options);
  } catch (const InputError& e) {
    throw InputError("--" + e.field(), e.reason());
  }
  const std::string yaml =
      io::team_scenario_yaml(io::default_scenario_yaml(), team, how_made, dem_path);
  // The loader's checks (placement, clearance, separation, threats) on the text as written.
  try {
    io::load_scenario(yaml, args.out.empty() ? "<generated>" : args.out,
                      std::filesystem::current_path());
  } catch (const InputError& e) {
    throw InputError("generated scenario", fmt::format("fails validation: {}", e.what()));
  }
  if (args.out.empty()) {
    std::cout << yaml;
    return;
  }
  io::write_file_atomically(args.out, yaml);
  std::cout << fmt::format("wrote {}: {} UAVs, {} targets, {} threats\n", args.out,
                           team.uavs.size(), team.targets.size(), team.threats.size());
}

}  // namespace

void register_scenario_command(CLI::App& app) {
  CLI::App* scenario = app.add_subcommand("scenario", "Scenario files");
  scenario->require_subcommand(1);
  CLI::App* print_default = scenario->add_subcommand(
      "default", "Print the embedded default scenario (DESIGN §7) as YAML you can edit");
  print_default->callback([] { std::cout << io::default_scenario_yaml(); });

  auto args = std::make_shared<TeamArgs>();
  CLI::App* team = scenario->add_subcommand(
      "team", "A team scenario: N UAVs on a take-off grid, M targets spread over the area");
  team->add_option("--uavs", args->uavs, "Number of UAVs (>= 1)")->required();
  team->add_option("--targets", args->targets, "Number of targets (>= 1)")->required();
  team->add_option("--seed", args->seed, "Seed of the targets, threats and the scenario")
      ->capture_default_str();
  team->add_option("--threats", args->threats,
                   "Number of threats (default: the default scenario's 3 per 4 km^2)");
  team->add_option("--dem", args->dem, "DEM raster (projected, metres) instead of the default "
                                       "terrain; the area is its extent");
  team->add_option("--out", args->out, "Write the scenario here (default: print it)");
  team->callback([args] {
    std::string how_made = fmt::format("ridgeline scenario team --uavs {} --targets {} --seed {}",
                                       args->uavs, args->targets, args->seed);
    if (!args->threats.empty()) how_made += " --threats " + args->threats;
    if (!args->dem.empty()) how_made += " --dem " + args->dem;
    write_team_scenario(*args, how_made);
  });
}

}  // namespace ridgeline::apps
