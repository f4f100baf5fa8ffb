#include "world/smooth_terrain.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace ridgeline::world {
namespace {

// Control points c_{-1} … c_n of the natural cubic B-spline through f_0 … f_{n−1} at unit
// spacing: (c_{i−1} + 4c_i + c_{i+1})/6 = f_i, and S'' = 0 at both ends, which gives
// c_0 = f_0, c_{n−1} = f_{n−1}, c_{−1} = 2c_0 − c_1, c_n = 2c_{n−1} − c_{n−2}; the interior is
// a tridiagonal system (Thomas' algorithm: diagonally dominant, stable).
void natural_controls(const double* f, int n, int stride, double* c) {
  // c has n + 2 entries at stride `stride`: c[0] is c_{−1}.
  auto C = [&](int i) -> double& { return c[(i + 1) * stride]; };
  if (n == 1) {
    C(-1) = C(0) = C(1) = f[0];
    return;
  }
  C(0) = f[0];
  C(n - 1) = f[(n - 1) * stride];
  const int m = n - 2;  // unknowns c_1 … c_{n−2}
  if (m > 0) {
    std::vector<double> diag(m, 4.0), rhs(m);
    for (int k = 0; k < m; ++k) rhs[k] = 6.0 * f[(k + 1) * stride];
    rhs[0] -= C(0);
    rhs[m - 1] -= C(n - 1);
    for (int k = 1; k < m; ++k) {
      const double w = 1.0 / diag[k - 1];
      diag[k] -= w;
      rhs[k] -= w * rhs[k - 1];
    }
    C(m) = rhs[m - 1] / diag[m - 1];
    for (int k = m - 2; k >= 0; --k) C(k + 1) = (rhs[k] - C(k + 2)) / diag[k];
  }
  C(-1) = 2.0 * C(0) - C(1);
  C(n) = 2.0 * C(n - 1) - C(n - 2);
}

// The four uniform cubic B-spline weights at t ∈ [0, 1] and their first and second derivatives.
void basis(double t, std::array<double, 4>& b, std::array<double, 4>& d1,
           std::array<double, 4>& d2) {
  const double t2 = t * t, t3 = t2 * t, u = 1.0 - t;
  b = {u * u * u / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
       (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0};
  d1 = {-0.5 * u * u, 1.5 * t2 - 2.0 * t, -1.5 * t2 + t + 0.5, 0.5 * t2};
  d2 = {u, 3.0 * t - 2.0, -3.0 * t + 1.0, t};
}

// Continuous index along an axis, clamped to the samples; the cell and the fraction in it.
bool locate(double coord, double origin, double cell, int n, int& index, double& frac) {
  double u = (coord - origin) / cell;
  const bool clamped = !(u >= 0.0 && u <= n - 1.0);
  if (clamped) u = u > n - 1.0 ? n - 1.0 : 0.0;  // NaN lands on 0 too
  index = std::clamp(static_cast<int>(std::floor(u)), 0, std::max(0, n - 2));
  frac = n == 1 ? 0.0 : u - index;
  return clamped || n == 1;
}

}  // namespace

BicubicSpline::BicubicSpline(const RasterGrid& grid)
    : rows_(grid.rows),
      cols_(grid.cols),
      origin_s_(grid.origin_x_m),
      origin_t_(grid.origin_y_m),
      cell_s_(grid.cell_x_m),
      cell_t_(grid.cell_y_m) {
  validate_raster_grid(grid, "terrain.raster");
  if (rows_ < 2 || cols_ < 2)
    throw InputError("terrain.raster", "a B-spline needs at least 2 x 2 samples");
  const int w = cols_ + 2;
  // Rows first (into the interior rows of the control grid), then every column.
  control_.assign(static_cast<std::size_t>(rows_ + 2) * w, 0.0);
  for (int r = 0; r < rows_; ++r)
    natural_controls(&grid.heights_m[static_cast<std::size_t>(r) * cols_], cols_, 1,
                     &control_[static_cast<std::size_t>(r + 1) * w]);
  std::vector<double> column(rows_), out(rows_ + 2);
  for (int c = 0; c < w; ++c) {
    for (int r = 0; r < rows_; ++r) column[r] = control_[static_cast<std::size_t>(r + 1) * w + c];
    natural_controls(column.data(), rows_, 1, out.data());
    for (int r = 0; r < rows_ + 2; ++r) control_[static_cast<std::size_t>(r) * w + c] = out[r];
  }
}

void BicubicSpline::raise_by(const std::vector<double>& cell_floor) {
  const int cell_rows = std::max(1, rows_ - 1), cell_cols = std::max(1, cols_ - 1);
  const int w = cols_ + 2;
  // Control (a, b) (spline indices a − 1, b − 1) weighs on cells a − 3 … a in each axis.
  for (int a = 0; a < rows_ + 2; ++a)
    for (int b = 0; b < w; ++b) {
      double raise = 0.0;
      for (int r = std::max(0, a - 3); r <= std::min(cell_rows - 1, a); ++r)
        for (int c = std::max(0, b - 3); c <= std::min(cell_cols - 1, b); ++c)
          raise = std::max(raise, cell_floor[static_cast<std::size_t>(r) * cell_cols + c]);
      control_[static_cast<std::size_t>(a) * w + b] += raise;
    }
}

Vec2 BicubicSpline::second_derivative_bound(int row, int col) const {
  const int w = cols_ + 2;
  const int j = std::clamp(row, 0, std::max(0, rows_ - 2)),
            i = std::clamp(col, 0, std::max(0, cols_ - 2));
  auto c = [&](int a, int b) { return control_[static_cast<std::size_t>(j + a) * w + i + b]; };
  double ss = 0.0, tt = 0.0;
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 2; ++b) {
      ss = std::max(ss, std::abs(c(a, b) - 2.0 * c(a, b + 1) + c(a, b + 2)));
      tt = std::max(tt, std::abs(c(b, a) - 2.0 * c(b + 1, a) + c(b + 2, a)));
    }
  return Vec2(ss / (cell_s_ * cell_s_), tt / (cell_t_ * cell_t_));
}

double BicubicSpline::evaluate(double s, double t, Vec2* gradient, Eigen::Matrix2d* hessian) const {
  int i = 0, j = 0;
  double u = 0.0, v = 0.0;
  const bool flat_s = locate(s, origin_s_, cell_s_, cols_, i, u);
  const bool flat_t = locate(t, origin_t_, cell_t_, rows_, j, v);
  std::array<double, 4> bs, ds, es, bt, dt, et;
  basis(u, bs, ds, es);
  basis(v, bt, dt, et);
  const int w = cols_ + 2;
  double value = 0.0, gs = 0.0, gt = 0.0, hss = 0.0, htt = 0.0, hst = 0.0;
  for (int a = 0; a < 4; ++a) {
    // Control row j − 1 + a is stored at index j + a (one ring of end controls).
    const double* row = &control_[static_cast<std::size_t>(j + a) * w + i];
    double r0 = 0.0, r1 = 0.0, r2 = 0.0;
    for (int b = 0; b < 4; ++b) {
      r0 += bs[b] * row[b];
      r1 += ds[b] * row[b];
      r2 += es[b] * row[b];
    }
    value += bt[a] * r0;
    gs += bt[a] * r1;
    gt += dt[a] * r0;
    hss += bt[a] * r2;
    htt += et[a] * r0;
    hst += dt[a] * r1;
  }
  if (gradient != nullptr)
    *gradient = Vec2(flat_s ? 0.0 : gs / cell_s_, flat_t ? 0.0 : gt / cell_t_);
  if (hessian != nullptr) {
    (*hessian)(0, 0) = flat_s ? 0.0 : hss / (cell_s_ * cell_s_);
    (*hessian)(1, 1) = flat_t ? 0.0 : htt / (cell_t_ * cell_t_);
    (*hessian)(0, 1) = (*hessian)(1, 0) = flat_s || flat_t ? 0.0 : hst / (cell_s_ * cell_t_);
  }
  return value;
}

namespace {

// A raster with a single row (column) gets a copy of it one cell north (east): the same
// bilinear surface (constant along that axis), and a spline with a cell to live in.
RasterGrid at_least_two(const RasterGrid& grid) {
  validate_raster_grid(grid, "terrain.raster");
  RasterGrid g = grid;
  if (g.cols == 1) {
    std::vector<double> h;
    for (int r = 0; r < g.rows; ++r) h.insert(h.end(), 2, g.at(r, 0));
    g.heights_m = std::move(h);
    g.cols = 2;
  }
  if (g.rows == 1) {
    g.heights_m.insert(g.heights_m.end(), g.heights_m.begin(), g.heights_m.end());
    g.rows = 2;
  }
  return g;
}

// Fine cells per raster cell and axis: 4, or fewer on a large raster (memory: 16 doubles a
// fine cell across the spline and the bound).
int refinement(const RasterGrid& g) {
  const double cells = static_cast<double>(g.rows - 1) * static_cast<double>(g.cols - 1);
  return cells <= 250000.0 ? 4 : cells <= 1000000.0 ? 2 : 1;
}

// The raster's bilinear surface sampled at cell/k over the same extent.
RasterGrid refined(const RasterGrid& grid, int k) {
  const RasterTerrain raster(grid);
  RasterGrid fine;
  fine.rows = (grid.rows - 1) * k + 1;
  fine.cols = (grid.cols - 1) * k + 1;
  fine.origin_x_m = grid.origin_x_m;
  fine.origin_y_m = grid.origin_y_m;
  fine.cell_x_m = grid.cell_x_m / k;
  fine.cell_y_m = grid.cell_y_m / k;
  fine.heights_m.reserve(static_cast<std::size_t>(fine.rows) * fine.cols);
  for (int r = 0; r < fine.rows; ++r)
    for (int c = 0; c < fine.cols; ++c)
      fine.heights_m.push_back(raster.height(fine.x_of_col(c), fine.y_of_row(r)));
  return fine;
}

}  // namespace

SmoothRasterTerrain::SmoothRasterTerrain(const RasterGrid& grid, const CoordinateMap* map,
                                         const PlanarBox& box, double exact_model_error_m)
    : SmoothRasterTerrain(at_least_two(grid), map, box, exact_model_error_m, 0) {}

SmoothRasterTerrain::SmoothRasterTerrain(const RasterGrid& g, const CoordinateMap* map,
                                         const PlanarBox& box, double exact_model_error_m, int)
    : spline_(refined(g, refinement(g))),
      mapped_(map != nullptr),
      exact_model_error_m_(exact_model_error_m) {
  if (map != nullptr) map_ = *map;
  const RasterTerrain raster(g);
  const int k = refinement(g);
  const int cell_rows = (g.rows - 1) * k, cell_cols = (g.cols - 1) * k;
  const double hs = g.cell_x_m / k, ht = g.cell_y_m / k;
  // 2. The raster's rise above the spline in every fine cell, at 3 × 3 points plus the bound
  // between them (spacing h/2): inside a fine cell the raster is linear along each axis, so
  // the difference's second derivatives along the axes are the spline's.
  std::vector<double> floor(static_cast<std::size_t>(cell_rows) * cell_cols, 0.0);
  for (int r = 0; r < cell_rows; ++r)
    for (int c = 0; c < cell_cols; ++c) {
      double rise = -std::numeric_limits<double>::infinity();
      for (int a = 0; a <= 2; ++a)
        for (int b = 0; b <= 2; ++b) {
          const double s = g.origin_x_m + (c + 0.5 * b) * hs;
          const double t = g.origin_y_m + (r + 0.5 * a) * ht;
          rise = std::max(rise, raster.height(s, t) - spline_.evaluate(s, t));
        }
      const Vec2 m = spline_.second_derivative_bound(r, c);
      const double between = (m.x() * 0.25 * hs * hs + m.y() * 0.25 * ht * ht) / 8.0;
      floor[static_cast<std::size_t>(r) * cell_cols + c] = std::max(0.0, rise + between);
    }
  // 3. Raised so that no cell lies below the raster.
  spline_.raise_by(floor);

  // The envelope's conservatism, and a check of its guarantee, over the box.
  double s_lo = std::numeric_limits<double>::infinity(), s_hi = -s_lo, t_lo = s_lo, t_hi = -s_lo;
  for (int a = 0; a <= 2; ++a)
    for (int b = 0; b <= 2; ++b) {
      const Vec2 p = source(box.x_min_m + 0.5 * a * (box.x_max_m - box.x_min_m),
                            box.y_min_m + 0.5 * b * (box.y_max_m - box.y_min_m), nullptr);
      s_lo = std::min(s_lo, p.x());
      s_hi = std::max(s_hi, p.x());
      t_lo = std::min(t_lo, p.y());
      t_hi = std::max(t_hi, p.y());
    }
  auto index = [](double v, int n) {
    return static_cast<int>(std::clamp(std::isfinite(v) ? v : 0.0, 0.0, n - 1.0));
  };
  const int c0 = index(std::floor((s_lo - g.origin_x_m) / hs), cell_cols);
  const int c1 = index(std::ceil((s_hi - g.origin_x_m) / hs), cell_cols);
  const int r0 = index(std::floor((t_lo - g.origin_y_m) / ht), cell_rows);
  const int r1 = index(std::ceil((t_hi - g.origin_y_m) / ht), cell_rows);
  envelope_above_m_ = 0.0;
  raster_above_m_ = -std::numeric_limits<double>::infinity();
  for (int r = r0; r <= r1; ++r)
    for (int c = c0; c <= c1; ++c)
      for (int a = 0; a <= 1; ++a)
        for (int b = 0; b <= 1; ++b) {
          const double s = g.origin_x_m + (c + 0.5 * b) * hs;
          const double t = g.origin_y_m + (r + 0.5 * a) * ht;
          const double d = raster.height(s, t) - spline_.evaluate(s, t);
          raster_above_m_ = std::max(raster_above_m_, d);
          envelope_above_m_ = std::max(envelope_above_m_, -d);
        }
}

Vec2 SmoothRasterTerrain::source(double x_m, double y_m, Eigen::Matrix2d* jacobian) const {
  if (!mapped_) {
    if (jacobian != nullptr) jacobian->setIdentity();
    return Vec2(x_m, y_m);
  }
  return map_.at(x_m, y_m, jacobian);
}

double SmoothRasterTerrain::height(double x_m, double y_m) const {
  const Vec2 s = source(x_m, y_m, nullptr);
  return spline_.evaluate(s.x(), s.y());
}

Vec2 SmoothRasterTerrain::gradient(double x_m, double y_m) const {
  Eigen::Matrix2d j;
  const Vec2 s = source(x_m, y_m, &j);
  Vec2 g;
  spline_.evaluate(s.x(), s.y(), &g);
  return j.transpose() * g;
}

Eigen::Matrix2d SmoothRasterTerrain::hessian(double x_m, double y_m) const {
  // Jᵀ ∇²S J: the map's own second derivative (its lattice cells' twist, ~1e-12 per metre
  // here) is left out.
  Eigen::Matrix2d j, h;
  const Vec2 s = source(x_m, y_m, &j);
  spline_.evaluate(s.x(), s.y(), nullptr, &h);
  return j.transpose() * h * j;
}

std::shared_ptr<const Terrain> make_smooth_terrain(const Terrain& exact, const PlanarBox& box) {
  if (const auto* mapped = dynamic_cast<const MappedRasterTerrain*>(&exact))
    return std::make_shared<SmoothRasterTerrain>(mapped->source().grid(), &mapped->map(), box,
                                                 exact.model_error_m());
  if (const auto* raster = dynamic_cast<const RasterTerrain*>(&exact)) {
    // Only the part around the box: a whole DEM may be millions of cells.
    const RasterGrid cut =
        crop(raster->grid(), box.x_min_m, box.x_max_m, box.y_min_m, box.y_max_m, 3);
    return std::make_shared<SmoothRasterTerrain>(cut, nullptr, box, exact.model_error_m());
  }
  return nullptr;
}

}  // namespace ridgeline::world
