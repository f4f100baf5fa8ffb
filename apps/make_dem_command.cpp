// `ridgeline make-dem`: writes a DEM with known answers — a scenario's terrain, or a random
// peak field — sampled on a grid with optional Gaussian noise, as GeoTIFF or ESRI ASCII grid.
// Together with `fit-dem` it shows how well a fit recovers known peaks.
#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <memory>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "core/error.hpp"
#include "io/dem_file.hpp"
#include "io/scenario_file.hpp"
#include "world/terrain_synthesis.hpp"

namespace ridgeline::apps {
namespace {

struct MakeDemArgs {
  std::string scenario;
  int random_peaks = 0;
  double cell_m = 2.0;
  double noise_m = 0.0;
  std::uint64_t seed = 1;
  int epsg = 32632;
  std::string out;
};

void run_make_dem(const MakeDemArgs& args) {
  if (!(args.cell_m > 0.0)) throw InputError("--cell", "must be positive");
  if (!(args.noise_m >= 0.0)) throw InputError("--noise", "must not be negative");
  const io::LoadedScenario loaded = load_scenario_argument(args.scenario);
  const mission::Area& area = loaded.scenario.area;
  std::shared_ptr<const world::Terrain> terrain = loaded.terrain;
  if (args.random_peaks > 0) {
    world::RandomPeaksOptions options;
    options.num_peaks = args.random_peaks;
    options.x_min_m = area.x_min_m;
    options.x_max_m = area.x_max_m;
    options.y_min_m = area.y_min_m;
    options.y_max_m = area.y_max_m;
    options.seed = args.seed;
    const world::PeakTerrainConfig peaks = world::random_peaks(options);
    std::cout << "random peaks (x_m, y_m, height_m, sigma_x_m, sigma_y_m):\n";
    for (const world::Peak& p : peaks.peaks) {
      std::cout << fmt::format("  {:8.1f} {:8.1f} {:7.1f} {:7.1f} {:7.1f}\n", p.x_m, p.y_m,
                               p.height_m, p.sigma_x_m, p.sigma_y_m);
    }
    terrain = std::make_shared<world::PeakTerrain>(peaks);
  } else if (args.random_peaks < 0) {
    throw InputError("--random-peaks", "must not be negative");
  }
  // Cell centres cover the area, so the DEM's south-west corner is the area's (local frame).
  const int cols = static_cast<int>(std::floor((area.x_max_m - area.x_min_m) / args.cell_m));
  const int rows = static_cast<int>(std::floor((area.y_max_m - area.y_min_m) / args.cell_m));
  if (cols < 2 || rows < 2) throw InputError("--cell", "larger than half the area");
  world::RasterGrid grid = world::sample_terrain(
      *terrain, rows, cols, Vec2(area.x_min_m + args.cell_m / 2, area.y_min_m + args.cell_m / 2),
      Vec2(args.cell_m, args.cell_m));
  world::add_height_noise(grid, args.noise_m, derive_seed(args.seed, 7));
  const std::filesystem::path out(args.out);
  if (out.extension() == ".asc") {
    io::write_dem_ascii_grid(out, grid);
  } else if (out.extension() == ".tif" || out.extension() == ".tiff") {
    io::write_dem_geotiff(out, grid, args.epsg);
  } else {
    throw InputError("--out", "must end in .tif, .tiff or .asc, got '" + args.out + "'");
  }
  std::cout << fmt::format("wrote {} ({} x {} cells of {} m, noise {} m)\n", args.out, cols, rows,
                           args.cell_m, args.noise_m);
}

}  // namespace

void register_make_dem_command(CLI::App& app) {
  auto args = std::make_shared<MakeDemArgs>();
  CLI::App* cmd = app.add_subcommand(
      "make-dem", "Write a DEM sampled from a scenario's terrain or from random peaks");
  cmd->add_option("--scenario", args->scenario, "scenario whose area (and terrain) to use");
  cmd->add_option("--random-peaks", args->random_peaks,
                  "draw this many random peaks (80-300 m) instead of the scenario's terrain");
  cmd->add_option("--cell", args->cell_m, "cell size in metres")->capture_default_str();
  cmd->add_option("--noise", args->noise_m, "std of Gaussian height noise in metres")
      ->capture_default_str();
  cmd->add_option("--seed", args->seed, "seed of the peaks and the noise")->capture_default_str();
  cmd->add_option("--epsg", args->epsg, "projected CRS written into a GeoTIFF")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "output DEM (.tif or .asc)")->required();
  cmd->callback([args] { run_make_dem(*args); });
}

}  // namespace ridgeline::apps
