// Fitting the peak field of eq. 12 to a DEM raster (DESIGN §4).
//
// Nonlinear least squares over θ = (H0, {x_i, y_i, h_i, a_i, b_i}_{i=1..K}):
//   min_θ  Σ_s (H_θ(x_s, y_s) − z_s)²
// over raster samples s (every `stride`-th row and column), solved by Ceres with
// Levenberg–Marquardt and analytic Jacobians (∂(h·e)/∂x_i = 2h·e·(x − x_i)/a², ∂/∂h = e,
// ∂/∂a = 2h·e·(x − x_i)²/a³, likewise in y).
//
// Seeding: the raster is box-smoothed against noise; local maxima survive a non-maximum
// suppression window; candidates are taken highest first if they are PROMINENT — the lowest
// point on the straight line to every already chosen seed lies at least min_prominence_m
// below the candidate (a cheap stand-in for the key col). Each seed's a_i, b_i come from its
// half-height extent: walking ±x (±y) from the top until the height above the base falls to
// a fraction f ≤ 1/2 of the peak's (or stops falling), a = d/√(−ln f). If fewer than K
// prominent maxima exist, the rest are seeded at the largest residual of the seeded model.
//
// The `max` combination is not differentiable where two peaks are equal. It is fitted in two
// stages: (1) the smooth soft-max  H0 + m + (1/β)·log Σ_i exp(β(h_i e_i − m)),  m = max_i h_i e_i,
// with β = softmax_sharpness / (peak relief), whose Jacobian is the softmax-weighted sum of the
// peaks' Jacobians; it over-estimates the max by at most log(K)/β where peaks are equal and
// converges like a smooth problem; (2) LM on the exact max from stage 1's optimum, with the
// dominant peak's Jacobian (a generalized gradient). LM accepts only steps that lower the
// exact cost, so stage 2 can only improve the returned (exact max) model. The `sum`
// combination is smooth and fitted in one stage.
//
// RMSE and max residual are always evaluated with the returned model on the FULL raster, and
// the returned config's model_error_m is that max |residual|.
#pragma once

#include <string>

#include "world/raster_grid.hpp"
#include "world/terrain.hpp"

namespace ridgeline::world {

struct TerrainFitOptions {
  int num_peaks = 6;  ///< K >= 1
  PeakCombination combination = PeakCombination::kMax;
  int max_iterations = 100;  ///< LM iterations per stage
  /// Use every stride-th row and column of the raster for the fit; 0 = automatic: the
  /// smallest stride that keeps at most max_fit_samples samples.
  int subsample_stride = 0;
  int max_fit_samples = 40000;
  int num_threads = 1;
  /// Minimum prominence (m) of a local maximum to seed a peak; <= 0 = automatic, 3 % of the
  /// raster's relief (max − low percentile).
  double min_prominence_m = 0.0;
  /// β·relief of the soft-max stage for `max`; larger is closer to the max but less smooth.
  double softmax_sharpness = 30.0;
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;
  double parameter_tolerance = 1e-10;
};

enum class TerrainFitStatus {
  kConverged,      ///< a tolerance was met
  kMaxIterations,  ///< stopped at max_iterations; the model is the best found so far
  kFailed,         ///< the solver reported a numerical failure
};
const char* to_string(TerrainFitStatus status);

struct TerrainFitResult {
  TerrainFitStatus status = TerrainFitStatus::kFailed;
  std::string message;        ///< solver's own words for the last stage
  PeakTerrainConfig terrain;  ///< fitted field, peaks highest first; model_error_m = max_residual_m
  double rmse_m = 0.0;        ///< over the full raster
  double max_residual_m = 0.0;    ///< max |H − z| over the full raster
  double initial_rmse_m = 0.0;    ///< of the seeded model, full raster
  int iterations = 0;             ///< LM iterations, all stages
  double time_s = 0.0;            ///< wall time of the whole fit (seeding and evaluation too)
  int stride = 1;                 ///< subsampling stride used
  int num_samples = 0;            ///< samples in the least-squares problem
  int num_seeds_from_maxima = 0;  ///< seeds that were prominent local maxima

  /// One paragraph: status, peaks, RMSE, max residual, iterations, time.
  std::string brief_report() const;
};

/// Fits K peaks plus a base elevation to `grid`. Throws InputError on bad options
/// (field path `fit.<option>`) or a bad grid. Deterministic for a given grid and options.
TerrainFitResult fit_peak_terrain(const RasterGrid& grid, const TerrainFitOptions& options);

}  // namespace ridgeline::world
