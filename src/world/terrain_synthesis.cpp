#include "world/terrain_synthesis.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/error.hpp"
#include "core/random.hpp"

namespace ridgeline::world {

PeakTerrainConfig random_peaks(const RandomPeaksOptions& o) {
  if (o.num_peaks < 1) throw InputError("num_peaks", "must be at least 1");
  if (!(o.x_min_m < o.x_max_m) || !(o.y_min_m < o.y_max_m))
    throw InputError("area", "min must be below max");
  if (!(0.0 < o.min_height_m && o.min_height_m <= o.max_height_m))
    throw InputError("height", "need 0 < min_height_m <= max_height_m");
  if (!(0.0 < o.min_sigma_m && o.min_sigma_m <= o.max_sigma_m))
    throw InputError("sigma", "need 0 < min_sigma_m <= max_sigma_m");
  Rng rng(o.seed);
  PeakTerrainConfig config;
  constexpr int kMaxTries = 10000;
  for (int tries = 0; static_cast<int>(config.peaks.size()) < o.num_peaks; ++tries) {
    if (tries > kMaxTries) {
      throw InputError("num_peaks",
                       fmt::format("cannot place {} peaks {} m apart in the area", o.num_peaks,
                                   o.min_separation_m));
    }
    Peak p;
    p.x_m = rng.uniform(o.x_min_m, o.x_max_m);
    p.y_m = rng.uniform(o.y_min_m, o.y_max_m);
    p.height_m = rng.uniform(o.min_height_m, o.max_height_m);
    p.sigma_x_m = rng.uniform(o.min_sigma_m, o.max_sigma_m);
    p.sigma_y_m = rng.uniform(o.min_sigma_m, o.max_sigma_m);
    bool far_enough = true;
    for (const Peak& q : config.peaks)
      far_enough &= std::hypot(p.x_m - q.x_m, p.y_m - q.y_m) >= o.min_separation_m;
    if (far_enough) config.peaks.push_back(p);
  }
  return config;
}

void add_height_noise(RasterGrid& grid, double noise_std_m, std::uint64_t seed) {
  if (!(noise_std_m >= 0.0)) throw InputError("noise", "must be a non-negative number");
  Rng rng(seed);
  for (double& h : grid.heights_m) h += rng.normal(0.0, noise_std_m);
}

}  // namespace ridgeline::world
