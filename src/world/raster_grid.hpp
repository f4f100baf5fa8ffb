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

}  // namespace ridgeline::world
