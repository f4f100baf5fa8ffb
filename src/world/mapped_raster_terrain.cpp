#include "world/mapped_raster_terrain.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace ridgeline::world {
namespace {

// Continuous lattice index of `coord` and the cell it falls in: inside, floor(t) (the last
// node belongs to the cell before it); beyond the lattice, the border cell, extended.
void lattice_axis(double coord, double origin, double spacing, int n, int& index, double& frac) {
  const double t = (coord - origin) / spacing;
  // Clamped as a double first: a wild trial point must not overflow the int conversion.
  index = static_cast<int>(std::floor(std::clamp(std::isfinite(t) ? t : 0.0, 0.0, n - 2.0)));
  frac = t - index;
}

}  // namespace

Vec2 CoordinateMap::at(double x_m, double y_m, Mat2* jacobian) const {
  int i = 0, j = 0;
  double u = 0.0, v = 0.0;
  lattice_axis(x_m, x0_m, dx_m, nx, i, u);
  lattice_axis(y_m, y0_m, dy_m, ny, j, v);
  const std::size_t row = static_cast<std::size_t>(j) * static_cast<std::size_t>(nx);
  const Vec2& s00 = source[row + i];
  const Vec2& s01 = source[row + i + 1];
  const Vec2& s10 = source[row + nx + i];
  const Vec2& s11 = source[row + nx + i + 1];
  if (jacobian != nullptr) {
    jacobian->col(0) = ((1.0 - v) * (s01 - s00) + v * (s11 - s10)) / dx_m;
    jacobian->col(1) = ((1.0 - u) * (s10 - s00) + u * (s11 - s01)) / dy_m;
  }
  return (1.0 - u) * (1.0 - v) * s00 + u * (1.0 - v) * s01 + (1.0 - u) * v * s10 + u * v * s11;
}

void validate_coordinate_map(const CoordinateMap& map, const std::string& what) {
  if (map.nx < 2 || map.ny < 2)
    throw InputError(what, fmt::format("the coordinate map needs at least 2 x 2 nodes, got {} x {}",
                                       map.nx, map.ny));
  if (!(map.dx_m > 0.0 && std::isfinite(map.dx_m) && map.dy_m > 0.0 && std::isfinite(map.dy_m)) ||
      !std::isfinite(map.x0_m) || !std::isfinite(map.y0_m))
    throw InputError(what, "the coordinate map's lattice must be finite with positive spacing");
  if (map.source.size() != static_cast<std::size_t>(map.nx) * static_cast<std::size_t>(map.ny))
    throw InputError(what, "the coordinate map has the wrong number of nodes");
  for (const Vec2& s : map.source)
    if (!s.allFinite()) throw InputError(what, "the coordinate map has a non-finite node");
}

MappedRasterTerrain::MappedRasterTerrain(RasterGrid source, CoordinateMap map, double map_error_m,
                                         const std::string& what)
    : source_(std::move(source), 0.0, what), map_(std::move(map)), map_error_m_(map_error_m) {
  validate_coordinate_map(map_, what);
  if (!(map_error_m_ >= 0.0 && std::isfinite(map_error_m_)))
    throw InputError(what, "the coordinate map's error bound must be finite and >= 0");
}

double MappedRasterTerrain::height(double x_m, double y_m) const {
  const Vec2 s = map_.at(x_m, y_m);
  return source_.height(s.x(), s.y());
}

Vec2 MappedRasterTerrain::gradient(double x_m, double y_m) const {
  Vec2 g;
  height_and_gradient(x_m, y_m, g);  // the raster's height comes with its gradient, nearly free
  return g;
}

double MappedRasterTerrain::height_and_gradient(double x_m, double y_m, Vec2& gradient_out) const {
  Mat2 jacobian;
  const Vec2 s = map_.at(x_m, y_m, &jacobian);  // the same s as without the Jacobian
  Vec2 source_gradient;
  const double h = source_.height_and_gradient(s.x(), s.y(), source_gradient);
  gradient_out = jacobian.transpose() * source_gradient;
  return h;
}

Vec2 max_axis_slopes(const RasterGrid& grid) {
  Vec2 slope = Vec2::Zero();
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      if (c + 1 < grid.cols)
        slope.x() =
            std::max(slope.x(), std::abs(grid.at(r, c + 1) - grid.at(r, c)) / grid.cell_x_m);
      if (r + 1 < grid.rows)
        slope.y() =
            std::max(slope.y(), std::abs(grid.at(r + 1, c) - grid.at(r, c)) / grid.cell_y_m);
    }
  return slope;
}

}  // namespace ridgeline::world
