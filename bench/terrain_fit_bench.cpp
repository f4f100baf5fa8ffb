// Terrain fit on DEM-sized rasters (DESIGN §4): a 1000 × 1000 raster must fit in seconds.
// Data: the default scenario's six peaks (2 km × 2 km, 80–300 m) sampled every 2 m plus
// N(0, 1 m²) noise. Counters report the fit's RMSE and iterations next to the time.
#include <benchmark/benchmark.h>

#include "core/random.hpp"
#include "world/terrain.hpp"
#include "world/terrain_fit.hpp"

namespace {

using ridgeline::Vec2;
using namespace ridgeline::world;

RasterGrid noisy_dem(int n, PeakCombination combination) {
  PeakTerrainConfig config;
  config.combination = combination;
  config.base_elevation_m = 20.0;
  config.peaks = {{400.0, 450.0, 300.0, 180.0, 220.0},   {1200.0, 500.0, 220.0, 150.0, 120.0},
                  {1650.0, 1100.0, 260.0, 200.0, 170.0}, {700.0, 1300.0, 180.0, 130.0, 160.0},
                  {1300.0, 1700.0, 120.0, 110.0, 140.0}, {300.0, 1750.0, 80.0, 100.0, 90.0}};
  const double cell_m = 2000.0 / (n - 1);
  RasterGrid grid = sample_terrain(PeakTerrain(config), n, n, Vec2(0.0, 0.0), Vec2(cell_m, cell_m));
  ridgeline::Rng rng(2026);
  for (double& h : grid.heights_m) h += rng.normal(0.0, 1.0);
  return grid;
}

void BM_FitPeakTerrain(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto combination = state.range(1) == 0 ? PeakCombination::kMax : PeakCombination::kSum;
  const RasterGrid grid = noisy_dem(n, combination);
  TerrainFitOptions options;
  options.num_peaks = 6;
  options.combination = combination;
  TerrainFitResult result;
  for (auto _ : state) {
    result = fit_peak_terrain(grid, options);
    benchmark::DoNotOptimize(result);
  }
  state.counters["rmse_m"] = result.rmse_m;
  state.counters["max_residual_m"] = result.max_residual_m;
  state.counters["iterations"] = result.iterations;
  state.counters["stride"] = result.stride;
  state.SetLabel(combination == PeakCombination::kMax ? "max" : "sum");
}
BENCHMARK(BM_FitPeakTerrain)
    ->ArgsProduct({{201, 1000}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_PeakTerrainHeight(benchmark::State& state) {
  PeakTerrainConfig config;
  for (int i = 0; i < 8; ++i)
    config.peaks.push_back({250.0 * i, 200.0 * i, 100.0 + 20 * i, 150.0, 120.0});
  const PeakTerrain terrain(config);
  double x = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(terrain.height(x, 0.5 * x));
    x = x > 2000.0 ? 0.0 : x + 1.37;
  }
}
BENCHMARK(BM_PeakTerrainHeight);

void BM_RasterTerrainHeight(benchmark::State& state) {
  const RasterTerrain terrain(noisy_dem(1000, PeakCombination::kMax));
  double x = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(terrain.height(x, 0.5 * x));
    x = x > 2000.0 ? 0.0 : x + 1.37;
  }
}
BENCHMARK(BM_RasterTerrainHeight);

}  // namespace
