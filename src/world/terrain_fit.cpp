#include "world/terrain_fit.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "core/error.hpp"
#include "world/peak_field_cost.hpp"

namespace ridgeline::world {

namespace {

using fit_detail::Combine;
using fit_detail::kPeakParams;
using fit_detail::PeakFieldCost;
using fit_detail::Samples;

constexpr int kSamplesPerBlock = 512;  // residuals per Ceres residual block
constexpr double kMinPeakHeight_m = 1e-3;

// The model of the current parameters, evaluated exactly (max or sum).
double model_height(const std::vector<double>& peaks, double base, int num_peaks, bool sum,
                    double x, double y) {
  double field = 0.0;
  for (int i = 0; i < num_peaks; ++i) {
    const double* p = &peaks[static_cast<std::size_t>(i) * kPeakParams];
    const double dx = (x - p[0]) / p[3];
    const double dy = (y - p[1]) / p[4];
    const double v = p[2] * std::exp(-(dx * dx + dy * dy));
    field = sum ? field + v : std::max(field, v);
  }
  return base + field;
}

// A coarse working copy of the raster for seeding: every stride-th sample, 3×3 box-smoothed.
struct SeedGrid {
  int rows = 0, cols = 0;
  double x0 = 0, y0 = 0, dx = 1, dy = 1;  // centre of cell (0,0), spacing (centred coords)
  std::vector<double> z;
  double& at(int r, int c) { return z[static_cast<std::size_t>(r) * cols + c]; }
  double at(int r, int c) const { return z[static_cast<std::size_t>(r) * cols + c]; }
};

SeedGrid make_seed_grid(const RasterGrid& grid, int stride, double cx, double cy) {
  SeedGrid raw;
  raw.rows = (grid.rows - 1) / stride + 1;
  raw.cols = (grid.cols - 1) / stride + 1;
  raw.x0 = grid.origin_x_m - cx;
  raw.y0 = grid.origin_y_m - cy;
  raw.dx = grid.cell_x_m * stride;
  raw.dy = grid.cell_y_m * stride;
  raw.z.resize(static_cast<std::size_t>(raw.rows) * raw.cols);
  for (int r = 0; r < raw.rows; ++r) {
    for (int c = 0; c < raw.cols; ++c) raw.at(r, c) = grid.at(r * stride, c * stride);
  }
  SeedGrid smooth = raw;
  for (int r = 0; r < raw.rows; ++r) {
    for (int c = 0; c < raw.cols; ++c) {
      double sum = 0.0;
      int count = 0;
      for (int i = std::max(0, r - 1); i <= std::min(raw.rows - 1, r + 1); ++i) {
        for (int j = std::max(0, c - 1); j <= std::min(raw.cols - 1, c + 1); ++j) {
          sum += raw.at(i, j);
          ++count;
        }
      }
      smooth.at(r, c) = sum / count;
    }
  }
  return smooth;
}

// Half-height extent of a bump of height `top` (above 0) at (r0, c0) of `g` along (dr, dc):
// a = d/√(−ln f) from the first point where the fraction f = g/top falls to ≤ 1/2, or from the
// lowest point before the profile rises again (a col towards a neighbour) or leaves the grid.
// Returns 0 when the profile gives no estimate.
double half_height_sigma(const SeedGrid& g, int r0, int c0, int dr, int dc, double top,
                         double spacing) {
  double lowest = top;
  int lowest_k = 0;
  const double rise_tolerance = 0.02 * top;
  for (int k = 1;; ++k) {
    const int r = r0 + k * dr;
    const int c = c0 + k * dc;
    if (r < 0 || c < 0 || r >= g.rows || c >= g.cols) break;
    const double v = g.at(r, c);
    if (v < lowest) {
      lowest = v;
      lowest_k = k;
    }
    if (v <= 0.5 * top) break;
    if (v > lowest + rise_tolerance) break;
  }
  if (lowest_k == 0) return 0.0;
  const double f = std::clamp(lowest / top, 0.05, 0.95);
  return lowest_k * spacing / std::sqrt(-std::log(f));
}

struct SeedingResult {
  std::vector<double> peaks;  // K × [x, y, h, a, b]
  double base = 0.0;
  int from_maxima = 0;
};

SeedingResult seed_peaks(const SeedGrid& g, const TerrainFitOptions& options, double base,
                         double relief) {
  SeedingResult out;
  out.base = base;
  const double min_prominence =
      options.min_prominence_m > 0.0 ? options.min_prominence_m : 0.03 * relief;
  // Window of the non-maximum suppression: ~1/40 of the raster's shorter side, at least 2
  // cells so single-cell noise bumps on a slope are not maxima.
  const int window = std::max(2, std::min(g.rows, g.cols) / 40);
  struct Candidate {
    int r, c;
    double z;
  };
  std::vector<Candidate> candidates;
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) {
      const double v = g.at(r, c);
      bool is_max = true;
      for (int i = std::max(0, r - window); is_max && i <= std::min(g.rows - 1, r + window); ++i) {
        for (int j = std::max(0, c - window); j <= std::min(g.cols - 1, c + window); ++j) {
          // Strictly greater neighbours, or equal ones earlier in row-major order, win: a
          // flat top yields one maximum, not a plateau of them.
          const double w = g.at(i, j);
          if (w > v || (w == v && (i < r || (i == r && j < c)))) {
            is_max = false;
            break;
          }
        }
      }
      if (is_max) candidates.push_back({r, c, v});
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.z > b.z; });

  // Lowest point of the straight segment between two cells.
  const auto line_min = [&g](int r0, int c0, int r1, int c1) {
    const int steps = std::max(std::abs(r1 - r0), std::abs(c1 - c0));
    double lowest = std::numeric_limits<double>::infinity();
    for (int k = 0; k <= steps; ++k) {
      const double t = steps == 0 ? 0.0 : static_cast<double>(k) / steps;
      const int r = static_cast<int>(std::lround(r0 + t * (r1 - r0)));
      const int c = static_cast<int>(std::lround(c0 + t * (c1 - c0)));
      lowest = std::min(lowest, g.at(r, c));
    }
    return lowest;
  };

  const auto sigma_of = [&](const SeedGrid& field, int r, int c, double top, bool x_axis) {
    const double spacing = x_axis ? g.dx : g.dy;
    const double s1 = half_height_sigma(field, r, c, x_axis ? 0 : 1, x_axis ? 1 : 0, top, spacing);
    const double s2 =
        half_height_sigma(field, r, c, x_axis ? 0 : -1, x_axis ? -1 : 0, top, spacing);
    const int valid = (s1 > 0.0) + (s2 > 0.0);
    // No profile at all (a one-cell-wide raster): a few cells, the LM refines it.
    return valid == 0 ? 3.0 * spacing : (s1 + s2) / valid;
  };

  SeedGrid above = g;  // heights above the base: the bumps' own heights
  for (double& v : above.z) v -= base;

  std::vector<Candidate> chosen;
  for (const Candidate& cand : candidates) {
    if (static_cast<int>(chosen.size()) >= options.num_peaks) break;
    double col_height = base;
    for (const Candidate& s : chosen)
      col_height = std::max(col_height, line_min(cand.r, cand.c, s.r, s.c));
    if (cand.z - col_height < min_prominence) continue;
    chosen.push_back(cand);
    const double top = cand.z - base;
    out.peaks.insert(out.peaks.end(), {g.x0 + cand.c * g.dx, g.y0 + cand.r * g.dy, top,
                                       sigma_of(above, cand.r, cand.c, top, true),
                                       sigma_of(above, cand.r, cand.c, top, false)});
  }
  out.from_maxima = static_cast<int>(chosen.size());

  // Too few prominent maxima: peel the largest residual of the model seeded so far.
  const bool sum = options.combination == PeakCombination::kSum;
  while (static_cast<int>(out.peaks.size()) < options.num_peaks * kPeakParams) {
    const int k = static_cast<int>(out.peaks.size()) / kPeakParams;
    SeedGrid residual = g;
    int best_r = 0, best_c = 0;
    double best = -std::numeric_limits<double>::infinity();
    for (int r = 0; r < g.rows; ++r) {
      for (int c = 0; c < g.cols; ++c) {
        const double v =
            g.at(r, c) - model_height(out.peaks, base, k, sum, g.x0 + c * g.dx, g.y0 + r * g.dy);
        residual.at(r, c) = v;
        if (v > best) {
          best = v;
          best_r = r;
          best_c = c;
        }
      }
    }
    const double top = std::max(best, 0.01 * relief + kMinPeakHeight_m);
    out.peaks.insert(out.peaks.end(), {g.x0 + best_c * g.dx, g.y0 + best_r * g.dy, top,
                                       sigma_of(residual, best_r, best_c, top, true),
                                       sigma_of(residual, best_r, best_c, top, false)});
  }
  return out;
}

void validate_options(const TerrainFitOptions& o) {
  if (o.num_peaks < 1) {
    throw InputError("fit.num_peaks", fmt::format("must be >= 1, got {}", o.num_peaks));
  }
  if (o.max_iterations < 1) {
    throw InputError("fit.max_iterations", fmt::format("must be >= 1, got {}", o.max_iterations));
  }
  if (o.subsample_stride < 0) {
    throw InputError("fit.subsample_stride",
                     fmt::format("must be >= 0 (0 = automatic), got {}", o.subsample_stride));
  }
  if (o.max_fit_samples < 1) {
    throw InputError("fit.max_fit_samples", fmt::format("must be >= 1, got {}", o.max_fit_samples));
  }
  if (o.num_threads < 1) {
    throw InputError("fit.num_threads", fmt::format("must be >= 1, got {}", o.num_threads));
  }
  if (!std::isfinite(o.min_prominence_m)) {
    throw InputError("fit.min_prominence_m", "must be finite");
  }
  if (!(std::isfinite(o.softmax_sharpness) && o.softmax_sharpness > 0.0)) {
    throw InputError("fit.softmax_sharpness",
                     fmt::format("must be finite and > 0, got {}", o.softmax_sharpness));
  }
}

TerrainFitStatus status_of(const ceres::Solver::Summary& summary) {
  switch (summary.termination_type) {
    case ceres::CONVERGENCE:
      return TerrainFitStatus::kConverged;
    case ceres::NO_CONVERGENCE:
      return TerrainFitStatus::kMaxIterations;
    default:
      return TerrainFitStatus::kFailed;
  }
}

}  // namespace

const char* to_string(TerrainFitStatus status) {
  switch (status) {
    case TerrainFitStatus::kConverged:
      return "converged";
    case TerrainFitStatus::kMaxIterations:
      return "max_iterations";
    case TerrainFitStatus::kFailed:
      return "failed";
  }
  return "unknown";
}

std::string TerrainFitResult::brief_report() const {
  std::string out = fmt::format(
      "Terrain fit: {} ({}), {} {} peaks + base {:.2f} m, RMSE {:.3f} m, max residual {:.3f} m "
      "(seeded model RMSE {:.3f} m), {} iterations, {:.3f} s, {} samples (stride {})\n",
      to_string(status), message, terrain.peaks.size(),
      terrain.combination == PeakCombination::kMax ? "max" : "sum", terrain.base_elevation_m,
      rmse_m, max_residual_m, initial_rmse_m, iterations, time_s, num_samples, stride);
  for (std::size_t i = 0; i < terrain.peaks.size(); ++i) {
    const Peak& p = terrain.peaks[i];
    out +=
        fmt::format("  peak {}: x {:.1f} m, y {:.1f} m, height {:.1f} m, sigma {:.1f} x {:.1f} m\n",
                    i, p.x_m, p.y_m, p.height_m, p.sigma_x_m, p.sigma_y_m);
  }
  return out;
}

TerrainFitResult fit_peak_terrain(const RasterGrid& grid, const TerrainFitOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  validate_options(options);
  validate_raster_grid(grid, "fit.raster");

  TerrainFitResult result;
  const int K = options.num_peaks;
  const bool sum = options.combination == PeakCombination::kSum;

  // Stride: the smallest one whose sample count fits the budget.
  int stride = options.subsample_stride;
  if (stride == 0) {
    stride = 1;
    while (static_cast<long long>((grid.rows - 1) / stride + 1) * ((grid.cols - 1) / stride + 1) >
           options.max_fit_samples) {
      ++stride;
    }
  }
  result.stride = stride;

  // Fit in coordinates centred on the raster so projected coordinates of 1e5–1e6 m do not
  // cost digits in x − x_i.
  const double cx = grid.x_of_col(0.5 * (grid.cols - 1));
  const double cy = grid.y_of_row(0.5 * (grid.rows - 1));

  const SeedGrid seed_grid = make_seed_grid(grid, stride, cx, cy);
  std::vector<double> sorted = seed_grid.z;
  // Base seed: a low percentile, not the minimum, so noise does not drag it down.
  const auto pct = sorted.begin() + static_cast<std::ptrdiff_t>(0.02 * (sorted.size() - 1));
  std::nth_element(sorted.begin(), pct, sorted.end());
  const double base0 = *pct;
  const double top0 = *std::max_element(seed_grid.z.begin(), seed_grid.z.end());
  // Flat rasters still get a positive scale for β and the floors below.
  const double relief = std::max(top0 - base0, 1e-3);

  SeedingResult seeds = seed_peaks(seed_grid, options, base0, relief);
  result.num_seeds_from_maxima = seeds.from_maxima;

  Samples samples;
  for (int r = 0; r < grid.rows; r += stride) {
    for (int c = 0; c < grid.cols; c += stride) {
      samples.x.push_back(grid.x_of_col(c) - cx);
      samples.y.push_back(grid.y_of_row(r) - cy);
      samples.z.push_back(grid.at(r, c));
    }
  }
  const int n = static_cast<int>(samples.z.size());
  result.num_samples = n;

  // Full-raster residual statistics of a parameter vector (exact max or sum).
  const auto evaluate = [&](const std::vector<double>& peaks, double base, double& rmse,
                            double& max_abs) {
    double sq = 0.0;
    max_abs = 0.0;
    for (int r = 0; r < grid.rows; ++r) {
      const double y = grid.y_of_row(r) - cy;
      for (int c = 0; c < grid.cols; ++c) {
        const double e =
            model_height(peaks, base, K, sum, grid.x_of_col(c) - cx, y) - grid.at(r, c);
        sq += e * e;
        max_abs = std::max(max_abs, std::abs(e));
      }
    }
    rmse = std::sqrt(sq / static_cast<double>(grid.size()));
  };
  double unused_max = 0.0;
  evaluate(seeds.peaks, seeds.base, result.initial_rmse_m, unused_max);

  std::vector<double> params = seeds.peaks;
  double base = seeds.base;
  const double width_x = grid.cell_x_m * grid.cols;
  const double width_y = grid.cell_y_m * grid.rows;
  const double beta = options.softmax_sharpness / relief;

  const auto solve_stage = [&](Combine combine) {
    ceres::Problem::Options problem_options;
    ceres::Problem problem(problem_options);
    std::vector<double*> blocks{&base};
    for (int i = 0; i < K; ++i)
      blocks.push_back(&params[static_cast<std::size_t>(i) * kPeakParams]);
    for (int begin = 0; begin < n; begin += kSamplesPerBlock) {
      const int count = std::min(kSamplesPerBlock, n - begin);
      problem.AddResidualBlock(new PeakFieldCost(&samples, begin, count, K, combine, beta), nullptr,
                               blocks);
    }
    // Bounds keep the model valid (h, a, b > 0) and identifiable: a peak narrower than half a
    // sample spacing could hide between samples; centres may lie off the raster (a mountain
    // whose flank only is in the DEM) but not arbitrarily far.
    const double min_sigma_x = 0.5 * grid.cell_x_m * stride;
    const double min_sigma_y = 0.5 * grid.cell_y_m * stride;
    for (int i = 0; i < K; ++i) {
      double* p = blocks[static_cast<std::size_t>(1 + i)];
      p[2] = std::max(p[2], kMinPeakHeight_m);
      p[3] = std::clamp(p[3], min_sigma_x, 10.0 * width_x);
      p[4] = std::clamp(p[4], min_sigma_y, 10.0 * width_y);
      p[0] = std::clamp(p[0], -width_x, width_x);
      p[1] = std::clamp(p[1], -width_y, width_y);
      problem.SetParameterLowerBound(p, 0, -width_x);
      problem.SetParameterUpperBound(p, 0, width_x);
      problem.SetParameterLowerBound(p, 1, -width_y);
      problem.SetParameterUpperBound(p, 1, width_y);
      problem.SetParameterLowerBound(p, 2, kMinPeakHeight_m);
      problem.SetParameterLowerBound(p, 3, min_sigma_x);
      problem.SetParameterUpperBound(p, 3, 10.0 * width_x);
      problem.SetParameterLowerBound(p, 4, min_sigma_y);
      problem.SetParameterUpperBound(p, 4, 10.0 * width_y);
    }
    ceres::Solver::Options solver_options;
    solver_options.minimizer_type = ceres::TRUST_REGION;
    solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    // 5K + 1 parameters: a dense QR of the stacked Jacobian is small and robust to the mixed
    // scales of positions, heights and widths.
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.num_threads = options.num_threads;
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.gradient_tolerance = options.gradient_tolerance;
    solver_options.parameter_tolerance = options.parameter_tolerance;
    solver_options.logging_type = ceres::SILENT;
    solver_options.minimizer_progress_to_stdout = false;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    result.iterations += std::max(0, static_cast<int>(summary.iterations.size()) - 1);
    result.status = status_of(summary);
    result.message = summary.message;
  };

  if (sum) {
    solve_stage(Combine::kSum);
  } else {
    solve_stage(Combine::kSoftMax);
    if (result.status != TerrainFitStatus::kFailed) solve_stage(Combine::kHardMax);
  }

  evaluate(params, base, result.rmse_m, result.max_residual_m);

  PeakTerrainConfig& terrain = result.terrain;
  terrain.combination = options.combination;
  terrain.base_elevation_m = base;
  terrain.model_error_m = result.max_residual_m;
  for (int i = 0; i < K; ++i) {
    const double* p = &params[static_cast<std::size_t>(i) * kPeakParams];
    terrain.peaks.push_back({p[0] + cx, p[1] + cy, p[2], p[3], p[4]});
  }
  std::stable_sort(terrain.peaks.begin(), terrain.peaks.end(),
                   [](const Peak& a, const Peak& b) { return a.height_m > b.height_m; });
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace ridgeline::world
