#include "world/terrain_fit.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"
#include "world/peak_field_cost.hpp"
#include "world/raster_grid.hpp"
#include "world/terrain.hpp"

namespace ridgeline::world {
namespace {

// Six peaks like the default scenario (DESIGN §7): 2 km × 2 km, 80–300 m high.
PeakTerrainConfig six_peaks(PeakCombination combination) {
  PeakTerrainConfig config;
  config.combination = combination;
  config.base_elevation_m = 20.0;
  config.peaks = {{400.0, 450.0, 300.0, 180.0, 220.0},   {1200.0, 500.0, 220.0, 150.0, 120.0},
                  {1650.0, 1100.0, 260.0, 200.0, 170.0}, {700.0, 1300.0, 180.0, 130.0, 160.0},
                  {1300.0, 1700.0, 120.0, 110.0, 140.0}, {300.0, 1750.0, 80.0, 100.0, 90.0}};
  return config;
}

// The field sampled every 10 m over 2 km × 2 km plus N(0, 1 m²) noise.
RasterGrid noisy_dem(const PeakTerrainConfig& truth, std::uint64_t seed) {
  RasterGrid grid = sample_terrain(PeakTerrain(truth), 201, 201, Vec2(0.0, 0.0), Vec2(10.0, 10.0));
  Rng rng(seed);
  for (double& h : grid.heights_m) h += rng.normal(0.0, 1.0);
  return grid;
}

// Matches every true peak to its nearest fitted one and checks the parameters.
void expect_peaks_recovered(const PeakTerrainConfig& truth, const PeakTerrainConfig& fitted) {
  ASSERT_EQ(fitted.peaks.size(), truth.peaks.size());
  std::vector<bool> used(fitted.peaks.size(), false);
  for (const Peak& t : truth.peaks) {
    std::size_t best = 0;
    double best_d = 1e300;
    for (std::size_t i = 0; i < fitted.peaks.size(); ++i) {
      const double d = std::hypot(fitted.peaks[i].x_m - t.x_m, fitted.peaks[i].y_m - t.y_m);
      if (!used[i] && d < best_d) {
        best_d = d;
        best = i;
      }
    }
    used[best] = true;
    const Peak& f = fitted.peaks[best];
    // Tolerances: for one Gaussian peak with noise σ = 1 m on samples Δ = 20 m apart (the
    // automatic stride 2 of 10 m cells), the Fisher information gives standard errors
    // std(x_i) ≈ σΔ·√(2a/(πb))/h and std(h_i) ≈ σΔ·√(2/(πab)); for the weakest peak
    // (h 80 m, a 100 m, b 90 m) that is 0.21 m and 0.17 m. The bounds are ~7× those, and
    // widths (std similar to the centre's) within 2 %.
    EXPECT_LT(best_d, 1.5) << "peak at " << t.x_m << ", " << t.y_m;
    EXPECT_NEAR(f.height_m, t.height_m, 1.5) << "peak at " << t.x_m << ", " << t.y_m;
    EXPECT_NEAR(f.sigma_x_m, t.sigma_x_m, 0.02 * t.sigma_x_m) << "peak at " << t.x_m;
    EXPECT_NEAR(f.sigma_y_m, t.sigma_y_m, 0.02 * t.sigma_y_m) << "peak at " << t.x_m;
  }
}

TEST(TerrainFitTest, RecoversSixPeaksOfMaxFieldFromNoisyDem) {
  const PeakTerrainConfig truth = six_peaks(PeakCombination::kMax);
  const RasterGrid dem = noisy_dem(truth, 2026);
  TerrainFitOptions options;
  options.num_peaks = 6;
  options.combination = PeakCombination::kMax;
  const TerrainFitResult result = fit_peak_terrain(dem, options);
  SCOPED_TRACE(result.brief_report());
  EXPECT_NE(result.status, TerrainFitStatus::kFailed);
  // The noise alone has RMSE 1 m; a correct model leaves about that.
  EXPECT_LT(result.rmse_m, 2.0);
  EXPECT_GT(result.rmse_m, 0.9);
  // 40401 N(0,1) samples: the largest |noise| is ~4.3σ; model error adds a little.
  EXPECT_LT(result.max_residual_m, 6.0);
  EXPECT_DOUBLE_EQ(result.terrain.model_error_m, result.max_residual_m);
  EXPECT_NEAR(result.terrain.base_elevation_m, truth.base_elevation_m, 1.0);
  expect_peaks_recovered(truth, result.terrain);
  // The returned config is a valid terrain.
  EXPECT_NO_THROW(PeakTerrain{result.terrain});
}

TEST(TerrainFitTest, RecoversSixPeaksOfSumFieldFromNoisyDem) {
  const PeakTerrainConfig truth = six_peaks(PeakCombination::kSum);
  const RasterGrid dem = noisy_dem(truth, 7);
  TerrainFitOptions options;
  options.num_peaks = 6;
  options.combination = PeakCombination::kSum;
  const TerrainFitResult result = fit_peak_terrain(dem, options);
  SCOPED_TRACE(result.brief_report());
  EXPECT_NE(result.status, TerrainFitStatus::kFailed);
  EXPECT_LT(result.rmse_m, 2.0);
  expect_peaks_recovered(truth, result.terrain);
}

TEST(TerrainFitTest, OverlappingPeaksOfMaxFieldAreRecoveredThroughTheKink) {
  // Peaks 1.8 widths apart: a large part of the lower one is hidden under the max, and the
  // `max` and `sum` fields differ by tens of metres in the valley between them.
  PeakTerrainConfig truth;
  truth.combination = PeakCombination::kMax;
  truth.base_elevation_m = 20.0;
  truth.peaks = {{700.0, 800.0, 250.0, 200.0, 180.0},
                 {1050.0, 900.0, 180.0, 150.0, 160.0},
                 {1300.0, 1300.0, 120.0, 120.0, 100.0}};
  const RasterGrid dem = noisy_dem(truth, 5);
  TerrainFitOptions options;
  options.num_peaks = 3;
  options.combination = PeakCombination::kMax;
  const TerrainFitResult result = fit_peak_terrain(dem, options);
  SCOPED_TRACE(result.brief_report());
  EXPECT_LT(result.rmse_m, 2.0);
  expect_peaks_recovered(truth, result.terrain);
  // The wrong combination cannot represent the kink: its worst residual is far above the
  // noise (the max fit's is ~4σ).
  options.combination = PeakCombination::kSum;
  const TerrainFitResult wrong = fit_peak_terrain(dem, options);
  EXPECT_GT(wrong.max_residual_m, 10.0);
  EXPECT_LT(result.max_residual_m, 6.0);
}

TEST(TerrainFitTest, RmseAndMaxResidualAreOfTheFullRaster) {
  // Fit on a subsample, then recompute the statistics independently on every cell.
  const PeakTerrainConfig truth = six_peaks(PeakCombination::kMax);
  const RasterGrid dem = noisy_dem(truth, 99);
  TerrainFitOptions options;
  options.subsample_stride = 3;
  const TerrainFitResult result = fit_peak_terrain(dem, options);
  EXPECT_EQ(result.stride, 3);
  EXPECT_EQ(result.num_samples, 67 * 67);
  const PeakTerrain fitted(result.terrain);
  double sq = 0.0, worst = 0.0;
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const double e = fitted.height(dem.x_of_col(c), dem.y_of_row(r)) - dem.at(r, c);
      sq += e * e;
      worst = std::max(worst, std::abs(e));
    }
  }
  // Same sums in a different order of centring: agreement to rounding.
  EXPECT_NEAR(result.rmse_m, std::sqrt(sq / static_cast<double>(dem.size())), 1e-9);
  EXPECT_NEAR(result.max_residual_m, worst, 1e-9);
}

TEST(TerrainFitTest, AutomaticStrideKeepsSamplesWithinBudget) {
  const RasterGrid dem = noisy_dem(six_peaks(PeakCombination::kMax), 5);
  TerrainFitOptions options;
  options.max_fit_samples = 5000;
  const TerrainFitResult result = fit_peak_terrain(dem, options);
  EXPECT_LE(result.num_samples, 5000);
  // Stride 2 would give 101² = 10201 samples, stride 3 gives 67² = 4489.
  EXPECT_EQ(result.stride, 3);
}

TEST(PeakFieldCostTest, AnalyticJacobiansMatchCentralDifferences) {
  using fit_detail::Combine;
  using fit_detail::kPeakParams;
  // Three overlapping peaks and samples spread over them, in the fit's centred coordinates.
  fit_detail::Samples samples;
  Rng rng(17);
  for (int s = 0; s < 300; ++s) {
    samples.x.push_back(rng.uniform(-400, 400));
    samples.y.push_back(rng.uniform(-400, 400));
    samples.z.push_back(rng.uniform(0, 200));
  }
  double base = 15.0;
  std::vector<std::vector<double>> peaks = {{-100.0, 50.0, 200.0, 150.0, 120.0},
                                            {120.0, -80.0, 150.0, 100.0, 180.0},
                                            {30.0, 200.0, 90.0, 80.0, 70.0}};
  const int n = static_cast<int>(samples.z.size());
  for (const Combine combine : {Combine::kSum, Combine::kSoftMax, Combine::kHardMax}) {
    // β = 30/relief as in the fit: smooth enough for central differences to resolve.
    const fit_detail::PeakFieldCost cost(&samples, 0, n, 3, combine, 30.0 / 200.0);
    std::vector<double*> params{&base};
    for (auto& p : peaks) params.push_back(p.data());
    std::vector<std::vector<double>> jac(4);
    jac[0].resize(static_cast<std::size_t>(n));
    for (int i = 1; i < 4; ++i) jac[i].resize(static_cast<std::size_t>(n) * kPeakParams);
    std::vector<double*> jac_ptr{jac[0].data(), jac[1].data(), jac[2].data(), jac[3].data()};
    std::vector<double> residual(static_cast<std::size_t>(n));
    ASSERT_TRUE(cost.Evaluate(params.data(), residual.data(), jac_ptr.data()));
    std::vector<double> plus(residual.size()), minus(residual.size());
    for (int block = 0; block < 4; ++block) {
      const int size = block == 0 ? 1 : kPeakParams;
      for (int k = 0; k < size; ++k) {
        // Step 1e-4 of the parameter's scale: the truncation error (step² times the third
        // derivative) and the rounding error (1e-16·|r|/step) both stay below 1e-7 here, so
        // a tolerance of 1e-6·(1 + |J|) separates a wrong formula from numerical noise.
        const double step = 1e-4 * std::max(1.0, std::abs(params[block][k]));
        const double saved = params[block][k];
        params[block][k] = saved + step;
        cost.Evaluate(params.data(), plus.data(), nullptr);
        params[block][k] = saved - step;
        cost.Evaluate(params.data(), minus.data(), nullptr);
        params[block][k] = saved;
        for (int s = 0; s < n; ++s) {
          // Where the step crosses the exact max's kink there is no derivative to compare;
          // the second difference reveals the crossing.
          const double second_difference = plus[s] + minus[s] - 2 * residual[s];
          if (combine == Combine::kHardMax && std::abs(second_difference) > 1e-6) continue;
          const double numeric = (plus[s] - minus[s]) / (2 * step);
          const double analytic = jac[block][static_cast<std::size_t>(s) * size + k];
          EXPECT_NEAR(analytic, numeric, 1e-6 * (1.0 + std::abs(analytic)))
              << "combine " << static_cast<int>(combine) << " block " << block << " param " << k
              << " sample " << s;
        }
      }
    }
  }
}

TEST(TerrainFitTest, SinglePeakOnFlatGroundUsesResidualSeeding) {
  // Asking for two peaks where one exists: the second is seeded from the residual and must
  // not spoil the fit of the first.
  PeakTerrainConfig truth;
  truth.base_elevation_m = 5.0;
  truth.peaks = {{250.0, 250.0, 100.0, 80.0, 60.0}};
  const RasterGrid dem =
      sample_terrain(PeakTerrain(truth), 51, 51, Vec2(0.0, 0.0), Vec2(10.0, 10.0));
  TerrainFitOptions options;
  options.num_peaks = 2;
  const TerrainFitResult result = fit_peak_terrain(dem, options);
  SCOPED_TRACE(result.brief_report());
  EXPECT_EQ(result.num_seeds_from_maxima, 1);
  // Noise-free data of the model family: the fit is near exact.
  EXPECT_LT(result.max_residual_m, 0.5);
  ASSERT_EQ(result.terrain.peaks.size(), 2u);
  EXPECT_NEAR(result.terrain.peaks[0].height_m, 100.0, 0.5);
}

TEST(TerrainFitTest, RejectsBadOptions) {
  const RasterGrid dem = sample_terrain(PeakTerrain(six_peaks(PeakCombination::kMax)), 10, 10,
                                        Vec2(0.0, 0.0), Vec2(200.0, 200.0));
  TerrainFitOptions options;
  options.num_peaks = 0;
  try {
    fit_peak_terrain(dem, options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "fit.num_peaks");
  }
  options.num_peaks = 1;
  options.num_threads = 0;
  EXPECT_THROW(fit_peak_terrain(dem, options), InputError);
}

}  // namespace
}  // namespace ridgeline::world
