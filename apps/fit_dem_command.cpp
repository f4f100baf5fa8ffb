// `ridgeline fit-dem`: fits the peak terrain of eq. 12 to a DEM and writes it as YAML that a
// scenario includes with `terrain: {include: FILE}` (DESIGN §4).
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "apps/commands.hpp"
#include "core/error.hpp"
#include "io/dem_file.hpp"
#include "io/geo_frame.hpp"
#include "io/terrain_fit_file.hpp"
#include "world/terrain_fit.hpp"

namespace ridgeline::apps {

namespace {

struct FitDemArgs {
  std::string dem;
  int peaks = 6;
  std::string combination = "max";
  std::string out;
  int max_iterations = 100;
  int threads = 1;
  std::string origin;
};

void run_fit_dem(const FitDemArgs& args) {
  world::TerrainFitOptions options;
  if (args.peaks < 1) {
    throw InputError("--peaks", "must be >= 1, got " + std::to_string(args.peaks));
  }
  if (args.combination == "max") {
    options.combination = world::PeakCombination::kMax;
  } else if (args.combination == "sum") {
    options.combination = world::PeakCombination::kSum;
  } else {
    throw InputError("--combination", "must be max or sum, got '" + args.combination + "'");
  }
  options.num_peaks = args.peaks;
  options.max_iterations = args.max_iterations;
  options.num_threads = args.threads;
  // With an origin the DEM (in any CRS) is warped into the origin's frame, so the peaks are
  // where a scenario with the same origin puts them.
  std::optional<mission::GeodeticOrigin> origin;
  if (!args.origin.empty()) origin = io::parse_origin_text(args.origin, "--origin");
  const world::RasterGrid grid = origin ? io::load_dem_in_frame(args.dem, io::GeoFrame(*origin))
                                        : io::load_dem_local(args.dem);
  const world::TerrainFitResult fit = world::fit_peak_terrain(grid, options);
  std::cout << "DEM " << args.dem << ": " << grid.cols << " x " << grid.rows << " cells\n"
            << fit.brief_report();
  if (fit.status == world::TerrainFitStatus::kFailed) {
    // A failed fit is not a terrain anyone should fly over: nothing is written.
    throw InputError(args.dem, "the peak fit failed: " + fit.message);
  }
  io::write_terrain_fit_yaml(args.out, fit, args.dem, grid, origin);
  std::cout << "wrote " << args.out << '\n';
}

}  // namespace

void register_fit_dem_command(CLI::App& app) {
  auto args = std::make_shared<FitDemArgs>();
  CLI::App* cmd = app.add_subcommand(
      "fit-dem", "Fit K Gaussian peaks (eq. 12) to a DEM and write them as terrain YAML");
  cmd->add_option(
         "--dem", args->dem,
         "DEM file (GeoTIFF, ESRI .asc, SRTM .hgt; projected CRS, or any CRS with --origin)")
      ->required();
  cmd->add_option("--peaks", args->peaks, "number of peaks K (>= 1)")->required();
  cmd->add_option("--combination", args->combination, "how peaks combine: max | sum")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "output terrain YAML file")->required();
  cmd->add_option("--max-iterations", args->max_iterations,
                  "Levenberg-Marquardt iterations per stage")
      ->capture_default_str();
  cmd->add_option("--threads", args->threads, "threads for the fit")->capture_default_str();
  cmd->add_option("--origin", args->origin,
                  "LAT,LON,ALT_AMSL: fit in this geodetic origin's frame (DEMs in any CRS, e.g. "
                  "degrees); a scenario including the result must name the same origin");
  cmd->callback([args] { run_fit_dem(*args); });
}

}  // namespace ridgeline::apps
