// A regular grid of terrain heights (a DEM raster) over the ENU plane.
//
// Conventions (every producer and consumer of RasterGrid follows them):
// - Heights are samples at cell CENTRES. Cell (row, col) has its centre at
//     x = origin_x_m + col · cell_x_m,   y = origin_y_m + row · cell_y_m,
//   so (origin_x_m, origin_y_m) is the centre of the SOUTH-WEST cell.
// - Row 0 is the southernmost row and rows grow northwards (y up), columns grow eastwards.
//   This is the flip of a north-up GeoTIFF's row order; the DEM reader does the flip.
// - heights_m is row-major: heights_m[row · cols + col].
// - The cell area of the raster is [origin − cell/2, origin + (n − 1)·cell + cell/2] in each
//   axis; its south-west CORNER is therefore (origin_x_m − cell_x_m/2, origin_y_m − cell_y_m/2).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace ridgeline::world {

struct RasterGrid {
  int rows = 0;
  int cols = 0;
  double origin_x_m = 0.0;        ///< x of the south-west cell's centre
  double origin_y_m = 0.0;        ///< y of the south-west cell's centre
  double cell_x_m = 1.0;          ///< spacing of columns (east), > 0
  double cell_y_m = 1.0;          ///< spacing of rows (north), > 0
  std::vector<double> heights_m;  ///< rows·cols heights, row-major, row 0 south

  double& at(int row, int col) {
    return heights_m[static_cast<std::size_t>(row) * static_cast<std::size_t>(cols) +
                     static_cast<std::size_t>(col)];
  }
  double at(int row, int col) const {
    return heights_m[static_cast<std::size_t>(row) * static_cast<std::size_t>(cols) +
                     static_cast<std::size_t>(col)];
  }
  double x_of_col(double col) const { return origin_x_m + col * cell_x_m; }
  double y_of_row(double row) const { return origin_y_m + row * cell_y_m; }
  std::size_t size() const { return heights_m.size(); }
};

/// Throws InputError (field `what`, e.g. a file name or `terrain.raster`) unless the grid is
/// usable: rows, cols >= 1, finite positive cell sizes, finite origin, rows·cols finite heights.
inline void validate_raster_grid(const RasterGrid& grid, const std::string& what) {
  if (grid.rows < 1 || grid.cols < 1) {
    throw InputError(what, "raster must have at least one row and one column, got " +
                               std::to_string(grid.rows) + " x " + std::to_string(grid.cols));
  }
  if (!(std::isfinite(grid.cell_x_m) && grid.cell_x_m > 0.0) ||
      !(std::isfinite(grid.cell_y_m) && grid.cell_y_m > 0.0)) {
    throw InputError(what, "raster cell sizes must be finite and positive, got " +
                               std::to_string(grid.cell_x_m) + " x " +
                               std::to_string(grid.cell_y_m));
  }
  if (!std::isfinite(grid.origin_x_m) || !std::isfinite(grid.origin_y_m)) {
    throw InputError(what, "raster origin must be finite");
  }
  const std::size_t expected =
      static_cast<std::size_t>(grid.rows) * static_cast<std::size_t>(grid.cols);
  if (grid.heights_m.size() != expected) {
    throw InputError(what, "raster has " + std::to_string(grid.heights_m.size()) +
                               " heights but rows x cols = " + std::to_string(expected));
  }
  for (std::size_t i = 0; i < expected; ++i) {
    if (!std::isfinite(grid.heights_m[i])) {
      throw InputError(what, "raster height at row " + std::to_string(i / grid.cols) + ", col " +
                                 std::to_string(i % grid.cols) + " is not finite");
    }
  }
}

/// The part of `grid` whose cells cover [x_min, x_max] × [y_min, y_max] (in the grid's own
/// coordinates), plus `pad_cells` on every side, cut to the grid. Never empty: a rectangle
/// beyond the grid keeps its border cells.
inline RasterGrid crop(const RasterGrid& grid, double x_min, double x_max, double y_min,
                       double y_max, int pad_cells) {
  // Continuous indices are clamped as doubles first: a rectangle far off must not overflow.
  const auto index = [](double v, int n) {
    return static_cast<int>(std::clamp(std::isfinite(v) ? v : 0.0, 0.0, n - 1.0));
  };
  const int c0 =
      index(std::floor((x_min - grid.origin_x_m) / grid.cell_x_m) - pad_cells, grid.cols);
  const int c1 = index(std::ceil((x_max - grid.origin_x_m) / grid.cell_x_m) + pad_cells, grid.cols);
  const int r0 =
      index(std::floor((y_min - grid.origin_y_m) / grid.cell_y_m) - pad_cells, grid.rows);
  const int r1 = index(std::ceil((y_max - grid.origin_y_m) / grid.cell_y_m) + pad_cells, grid.rows);
  RasterGrid cut;
  cut.rows = std::max(1, r1 - r0 + 1);
  cut.cols = std::max(1, c1 - c0 + 1);
  cut.cell_x_m = grid.cell_x_m;
  cut.cell_y_m = grid.cell_y_m;
  cut.origin_x_m = grid.x_of_col(c0);
  cut.origin_y_m = grid.y_of_row(r0);
  cut.heights_m.reserve(static_cast<std::size_t>(cut.rows) * static_cast<std::size_t>(cut.cols));
  for (int r = r0; r < r0 + cut.rows; ++r)
    for (int c = c0; c < c0 + cut.cols; ++c) cut.heights_m.push_back(grid.at(r, c));
  return cut;
}

}  // namespace ridgeline::world
