// Synthetic terrain for tests, benchmarks and users who want a DEM with known answers:
// random peak fields (eq. 12) and rasters sampled from any terrain with Gaussian noise.
#pragma once

#include <cstdint>

#include "world/raster_grid.hpp"
#include "world/terrain.hpp"

namespace ridgeline::world {

/// Bounds of a random peak field over the rectangle [x_min, x_max] × [y_min, y_max].
struct RandomPeaksOptions {
  int num_peaks = 6;
  double x_min_m = 0.0, x_max_m = 2000.0;
  double y_min_m = 0.0, y_max_m = 2000.0;
  double min_height_m = 80.0, max_height_m = 300.0;
  double min_sigma_m = 100.0, max_sigma_m = 250.0;
  /// Peak centres are at least this far apart (rejection sampling), so every peak is
  /// identifiable in a fit.
  double min_separation_m = 300.0;
  std::uint64_t seed = 1;
};

/// Draws a `max` peak field; throws InputError when the separation cannot be met.
PeakTerrainConfig random_peaks(const RandomPeaksOptions& options);

/// Adds independent N(0, noise_std_m²) noise to every height (seeded, deterministic).
void add_height_noise(RasterGrid& grid, double noise_std_m, std::uint64_t seed);

}  // namespace ridgeline::world
