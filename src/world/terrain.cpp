#include "world/terrain.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/error.hpp"
#include "core/simd_clones.hpp"

namespace ridgeline::world {
namespace {

void check_batch(const Eigen::Ref<const Eigen::MatrixXd>& positions_m, std::size_t heights,
                 std::size_t gradients) {
  const auto n = static_cast<std::size_t>(positions_m.cols());
  if (positions_m.rows() < 2 || heights != n || gradients != n) {
    throw std::invalid_argument(fmt::format(
        "Terrain::heights_and_gradients: {} x {} positions for {} heights and {} gradients",
        positions_m.rows(), positions_m.cols(), heights, gradients));
  }
}

}  // namespace

double Terrain::height_and_gradient(double x_m, double y_m, Vec2& gradient_out) const {
  gradient_out = gradient(x_m, y_m);
  return height(x_m, y_m);
}

void Terrain::heights_and_gradients(const Eigen::Ref<const Eigen::MatrixXd>& positions_m,
                                    std::span<double> heights_m, std::span<Vec2> gradients) const {
  check_batch(positions_m, heights_m.size(), gradients.size());
  for (Eigen::Index j = 0; j < positions_m.cols(); ++j) {
    const auto k = static_cast<std::size_t>(j);
    heights_m[k] = height_and_gradient(positions_m(0, j), positions_m(1, j), gradients[k]);
  }
}

Eigen::Matrix2d Terrain::hessian(double x_m, double y_m) const {
  // The peaks' widths and raster cells are tens of metres or more, so truncation (∝ h²) and
  // round-off (∝ 1e-16/h) are both tiny at 1 mm.
  constexpr double h = 1e-3;  // m
  const Vec2 dx = (gradient(x_m + h, y_m) - gradient(x_m - h, y_m)) / (2.0 * h);
  const Vec2 dy = (gradient(x_m, y_m + h) - gradient(x_m, y_m - h)) / (2.0 * h);
  Eigen::Matrix2d H;
  H(0, 0) = dx.x();
  H(1, 1) = dy.y();
  H(0, 1) = H(1, 0) = 0.5 * (dx.y() + dy.x());
  return H;
}

namespace {

void require_finite(double value, const std::string& field) {
  if (!std::isfinite(value)) throw InputError(field, fmt::format("must be finite, got {}", value));
}

void require_positive(double value, const std::string& field) {
  if (!std::isfinite(value) || value <= 0.0) {
    throw InputError(field, fmt::format("must be finite and > 0, got {}", value));
  }
}

// The exponent q = ((x − x0)/a)² + ((y − y0)/b)² of one peak at (x, y).
double peak_exponent(const Peak& p, double x_m, double y_m) {
  const double dx = (x_m - p.x_m) / p.sigma_x_m;
  const double dy = (y_m - p.y_m) / p.sigma_y_m;
  return dx * dx + dy * dy;
}

// h·e of one peak (eq. 12's term) at (x, y).
double peak_value(const Peak& p, double x_m, double y_m) {
  return p.height_m * std::exp(-peak_exponent(p, x_m, y_m));
}

Vec2 peak_gradient(const Peak& p, double value, double x_m, double y_m) {
  return Vec2(-2.0 * value * (x_m - p.x_m) / (p.sigma_x_m * p.sigma_x_m),
              -2.0 * value * (y_m - p.y_m) / (p.sigma_y_m * p.sigma_y_m));
}

// The dominant peak: the highest score ln h_i − q_i (the lowest index on a tie), or 0 when no
// score is above −∞ (a NaN position). The peaks are given as columns, with the reciprocals of
// their widths (no division). The terrain is read at every predicted position of every MPC step
// and at every slot-search sample, and this search is most of a read: scores and their maximum
// are taken in one pass, four peaks at a time in lanes that each keep their best. The scores
// only choose the peak; its value is computed again as before (peak_exponent), so a score's
// round-off matters only where two peaks tie to round-off.
RIDGELINE_SIMD_CLONES int best_peak(const double* __restrict x0, const double* __restrict y0,
                                    const double* __restrict inv_sx,
                                    const double* __restrict inv_sy,
                                    const double* __restrict log_h, int n, double x_m,
                                    double y_m) {
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  int best = 0;
  double best_score = kNone;
  int i = 0;
  if (n >= 8) {
    const Vec4 x = {x_m, x_m, x_m, x_m}, y = {y_m, y_m, y_m, y_m};
    Vec4 lane_score = {kNone, kNone, kNone, kNone};
    Mask4 lane_index = {-1, -1, -1, -1}, index = {0, 1, 2, 3};
    const Mask4 four = {4, 4, 4, 4};
    for (; i + 4 <= n; i += 4) {
      Vec4 px, py, sx, sy, lh;
      std::memcpy(&px, x0 + i, sizeof px);
      std::memcpy(&py, y0 + i, sizeof py);
      std::memcpy(&sx, inv_sx + i, sizeof sx);
      std::memcpy(&sy, inv_sy + i, sizeof sy);
      std::memcpy(&lh, log_h + i, sizeof lh);
      const Vec4 dx = (x - px) * sx, dy = (y - py) * sy;
      const Vec4 score = lh - (dx * dx + dy * dy);
      const Mask4 better = score > lane_score;  // strict: a lane keeps its first on a tie
      lane_score = better ? score : lane_score;
      lane_index = better ? index : lane_index;
      index += four;
    }
    for (int l = 0; l < 4; ++l) {  // the lanes hold different peaks: the lowest on a tie
      if (lane_index[l] < 0) continue;
      const int candidate = static_cast<int>(lane_index[l]);
      if (lane_score[l] > best_score || (lane_score[l] == best_score && candidate < best)) {
        best = candidate;
        best_score = lane_score[l];
      }
    }
  }
  for (; i < n; ++i) {  // later peaks than any lane's: strictly better only
    const double dx = (x_m - x0[i]) * inv_sx[i];
    const double dy = (y_m - y0[i]) * inv_sy[i];
    const double score = log_h[i] - (dx * dx + dy * dy);
    if (score > best_score) {
      best = i;
      best_score = score;
    }
  }
  return best;
}

// best_peak for four positions at a time, one a lane: each peak's score is the same
// expression, and the choice the same (the highest score; strict > over the peaks in order
// keeps the lowest index on a tie; 0 when none is above −∞), without best_peak's
// data-dependent branches. The last one to three positions go to best_peak.
RIDGELINE_SIMD_CLONES void best_peaks(const double* __restrict x0, const double* __restrict y0,
                                      const double* __restrict inv_sx,
                                      const double* __restrict inv_sy,
                                      const double* __restrict log_h, int n,
                                      const double* __restrict xs, const double* __restrict ys,
                                      int count, int* __restrict best) {
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  int j = 0;
  for (; j + 4 <= count; j += 4) {
    Vec4 x, y;
    std::memcpy(&x, xs + j, sizeof x);
    std::memcpy(&y, ys + j, sizeof y);
    Vec4 best_score = {kNone, kNone, kNone, kNone};
    Mask4 best_index = {0, 0, 0, 0};
    for (int i = 0; i < n; ++i) {
      const Vec4 px = {x0[i], x0[i], x0[i], x0[i]}, py = {y0[i], y0[i], y0[i], y0[i]};
      const Vec4 sx = {inv_sx[i], inv_sx[i], inv_sx[i], inv_sx[i]};
      const Vec4 sy = {inv_sy[i], inv_sy[i], inv_sy[i], inv_sy[i]};
      const Vec4 lh = {log_h[i], log_h[i], log_h[i], log_h[i]};
      const Vec4 dx = (x - px) * sx, dy = (y - py) * sy;
      const Vec4 score = lh - (dx * dx + dy * dy);
      const Mask4 better = score > best_score;
      const Mask4 index = {i, i, i, i};
      best_score = better ? score : best_score;
      best_index = better ? index : best_index;
    }
    for (int l = 0; l < 4; ++l) best[j + l] = static_cast<int>(best_index[l]);
  }
  for (; j < count; ++j) best[j] = best_peak(x0, y0, inv_sx, inv_sy, log_h, n, xs[j], ys[j]);
}

}  // namespace

void validate_peak_terrain_config(const PeakTerrainConfig& config, const std::string& path) {
  require_finite(config.base_elevation_m, path + ".base_elevation_m");
  if (!std::isfinite(config.model_error_m) || config.model_error_m < 0.0) {
    throw InputError(path + ".model_error_m",
                     fmt::format("must be finite and >= 0, got {}", config.model_error_m));
  }
  for (std::size_t i = 0; i < config.peaks.size(); ++i) {
    const Peak& p = config.peaks[i];
    const std::string at = fmt::format("{}.peaks[{}]", path, i);
    require_finite(p.x_m, at + ".x_m");
    require_finite(p.y_m, at + ".y_m");
    require_positive(p.height_m, at + ".height_m");
    require_positive(p.sigma_x_m, at + ".sigma_x_m");
    require_positive(p.sigma_y_m, at + ".sigma_y_m");
  }
}

PeakTerrain::PeakTerrain(PeakTerrainConfig config, const std::string& path)
    : config_(std::move(config)) {
  validate_peak_terrain_config(config_, path);
  for (const Peak& p : config_.peaks) {
    log_height_.push_back(std::log(p.height_m));
    peak_x_.push_back(p.x_m);
    peak_y_.push_back(p.y_m);
    peak_inv_sigma_x_.push_back(1.0 / p.sigma_x_m);
    peak_inv_sigma_y_.push_back(1.0 / p.sigma_y_m);
  }
}

const Peak* PeakTerrain::dominant(double x_m, double y_m, double* value) const {
  const int n = static_cast<int>(config_.peaks.size());
  if (n == 0) {
    *value = 0.0;
    return nullptr;
  }
  const int best = best_peak(peak_x_.data(), peak_y_.data(), peak_inv_sigma_x_.data(),
                             peak_inv_sigma_y_.data(), log_height_.data(), n, x_m, y_m);
  const Peak& p = config_.peaks[static_cast<std::size_t>(best)];
  *value = p.height_m * std::exp(-peak_exponent(p, x_m, y_m));
  return &p;
}

double PeakTerrain::height(double x_m, double y_m) const {
  double field = 0.0;
  if (config_.combination == PeakCombination::kSum) {
    for (const Peak& p : config_.peaks) field += peak_value(p, x_m, y_m);
  } else {
    dominant(x_m, y_m, &field);
  }
  return config_.base_elevation_m + field;
}

Vec2 PeakTerrain::gradient(double x_m, double y_m) const {
  Vec2 g = Vec2::Zero();
  if (config_.combination == PeakCombination::kSum) {
    for (const Peak& p : config_.peaks) g += peak_gradient(p, peak_value(p, x_m, y_m), x_m, y_m);
    return g;
  }
  double value = 0.0;
  const Peak* peak = dominant(x_m, y_m, &value);
  if (peak != nullptr) g = peak_gradient(*peak, value, x_m, y_m);
  return g;
}

double PeakTerrain::height_and_gradient(double x_m, double y_m, Vec2& gradient_out) const {
  // The same sums as height() and gradient(), each peak's value taken once.
  double field = 0.0;
  gradient_out = Vec2::Zero();
  if (config_.combination == PeakCombination::kSum) {
    for (const Peak& p : config_.peaks) {
      const double v = peak_value(p, x_m, y_m);
      field += v;
      gradient_out += peak_gradient(p, v, x_m, y_m);
    }
  } else if (const Peak* peak = dominant(x_m, y_m, &field)) {
    gradient_out = peak_gradient(*peak, field, x_m, y_m);
  }
  return config_.base_elevation_m + field;
}

void PeakTerrain::heights_and_gradients(const Eigen::Ref<const Eigen::MatrixXd>& positions_m,
                                        std::span<double> heights_m,
                                        std::span<Vec2> gradients) const {
  const int n = static_cast<int>(config_.peaks.size());
  if (config_.combination == PeakCombination::kSum || n == 0) {
    Terrain::heights_and_gradients(positions_m, heights_m, gradients);
    return;
  }
  check_batch(positions_m, heights_m.size(), gradients.size());
  constexpr int kBatch = 16;  // positions a call of best_peaks (on the stack)
  double xs[kBatch], ys[kBatch];
  int best[kBatch];
  const int total = static_cast<int>(positions_m.cols());
  for (int begin = 0; begin < total; begin += kBatch) {
    const int count = std::min(kBatch, total - begin);
    for (int k = 0; k < count; ++k) {
      xs[k] = positions_m(0, begin + k);
      ys[k] = positions_m(1, begin + k);
    }
    best_peaks(peak_x_.data(), peak_y_.data(), peak_inv_sigma_x_.data(),
               peak_inv_sigma_y_.data(), log_height_.data(), n, xs, ys, count, best);
    for (int k = 0; k < count; ++k) {  // as dominant() and height_and_gradient()
      const Peak& p = config_.peaks[static_cast<std::size_t>(best[k])];
      const double value = p.height_m * std::exp(-peak_exponent(p, xs[k], ys[k]));
      const auto out = static_cast<std::size_t>(begin + k);
      gradients[out] = peak_gradient(p, value, xs[k], ys[k]);
      heights_m[out] = config_.base_elevation_m + value;
    }
  }
}

RasterTerrain::RasterTerrain(RasterGrid grid, double model_error_m, const std::string& what)
    : grid_(std::move(grid)), model_error_m_(model_error_m) {
  validate_raster_grid(grid_, what);
  if (!std::isfinite(model_error_m) || model_error_m < 0.0) {
    throw InputError(what + ".model_error_m",
                     fmt::format("must be finite and >= 0, got {}", model_error_m));
  }
}

RasterTerrain::Cell RasterTerrain::locate(double x_m, double y_m) const {
  Cell cell;
  // One axis at a time: continuous index t = (coord − origin)/spacing, clamped to [0, n − 1];
  // the cell is floor(t) except on the last centre, which belongs to the cell before it.
  const auto axis = [](double coord, double origin, double spacing, int n, int& index, double& frac,
                       bool& clamped) {
    const double t = (coord - origin) / spacing;
    const double t_max = static_cast<double>(n - 1);
    clamped = !(t >= 0.0 && t <= t_max);  // also true for NaN, which then maps to index 0
    const double tc = clamped ? (t > t_max ? t_max : 0.0) : t;
    if (n == 1) {
      index = 0;
      frac = 0.0;
      clamped = true;
      return;
    }
    index = std::min(static_cast<int>(std::floor(tc)), n - 2);
    frac = tc - index;
  };
  axis(x_m, grid_.origin_x_m, grid_.cell_x_m, grid_.cols, cell.col, cell.u, cell.clamped_x);
  axis(y_m, grid_.origin_y_m, grid_.cell_y_m, grid_.rows, cell.row, cell.v, cell.clamped_y);
  return cell;
}

RasterTerrain::Patch RasterTerrain::patch(double x_m, double y_m) const {
  Patch p;
  p.cell = locate(x_m, y_m);
  const int c1 = std::min(p.cell.col + 1, grid_.cols - 1);
  const int r1 = std::min(p.cell.row + 1, grid_.rows - 1);
  p.h00 = grid_.at(p.cell.row, p.cell.col);
  p.h01 = grid_.at(p.cell.row, c1);
  p.h10 = grid_.at(r1, p.cell.col);
  p.h11 = grid_.at(r1, c1);
  return p;
}

double RasterTerrain::patch_height(const Patch& p) {
  const Cell& c = p.cell;
  return (1.0 - c.u) * (1.0 - c.v) * p.h00 + c.u * (1.0 - c.v) * p.h01 +
         (1.0 - c.u) * c.v * p.h10 + c.u * c.v * p.h11;
}

Vec2 RasterTerrain::patch_gradient(const Patch& p) const {
  const Cell& c = p.cell;
  Vec2 g;
  g.x() = c.clamped_x ? 0.0
                      : ((1.0 - c.v) * (p.h01 - p.h00) + c.v * (p.h11 - p.h10)) / grid_.cell_x_m;
  g.y() = c.clamped_y ? 0.0
                      : ((1.0 - c.u) * (p.h10 - p.h00) + c.u * (p.h11 - p.h01)) / grid_.cell_y_m;
  return g;
}

double RasterTerrain::height(double x_m, double y_m) const { return patch_height(patch(x_m, y_m)); }

Vec2 RasterTerrain::gradient(double x_m, double y_m) const {
  return patch_gradient(patch(x_m, y_m));
}

double RasterTerrain::height_and_gradient(double x_m, double y_m, Vec2& gradient_out) const {
  const Patch p = patch(x_m, y_m);
  gradient_out = patch_gradient(p);
  return patch_height(p);
}

RasterGrid sample_terrain(const Terrain& terrain, int rows, int cols, const Vec2& origin_m,
                          const Vec2& cell_m) {
  RasterGrid grid;
  grid.rows = rows;
  grid.cols = cols;
  grid.origin_x_m = origin_m.x();
  grid.origin_y_m = origin_m.y();
  grid.cell_x_m = cell_m.x();
  grid.cell_y_m = cell_m.y();
  if (rows < 1 || cols < 1) {
    throw InputError("sample_terrain",
                     fmt::format("need rows, cols >= 1, got {} x {}", rows, cols));
  }
  grid.heights_m.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols));
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c)
      grid.at(r, c) = terrain.height(grid.x_of_col(c), grid.y_of_row(r));
  }
  validate_raster_grid(grid, "sample_terrain");
  return grid;
}

}  // namespace ridgeline::world
