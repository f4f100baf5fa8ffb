// A DEM queried on its own pixels (issue 18): the terrain of a scenario whose DEM is in another
// CRS than the local frame (SRTM in degrees, a UTM GeoTIFF, ...).
//
// Warping the DEM onto a grid of the local frame resamples it, and a resampled grid can cut
// the top off a sharp ridge (a 38 m reported clearance was 33 m on the source tile). Instead,
// a point (x, y) of the local frame is carried to the DEM's own coordinates (s, t) (degrees or
// its CRS's units) and the height is the DEM's bilinear interpolation there, on its pixels:
//   H(x, y) = H_src(s(x, y), t(x, y)),   ∇H = Jᵀ·∇H_src,   J = ∂(s, t)/∂(x, y).
// The map (s, t)(x, y) is a projection (PROJ), smooth at the scale of a few kilometres; it is
// tabulated on a lattice of the local frame and interpolated bilinearly, which is exact to
// well under a millimetre at a 50 m spacing (the builder measures the largest interpolation
// error at every lattice cell's centre against PROJ and turns it into a height bound through
// the DEM's steepest slope: model_error_m()).
#pragma once

#include <string>
#include <vector>

#include "core/types.hpp"
#include "world/raster_grid.hpp"
#include "world/terrain.hpp"

namespace ridgeline::world {

using Mat2 = Eigen::Matrix2d;

/// A smooth map from the local frame to a DEM's own coordinates, tabulated on a lattice:
/// node (i, j) at (x0 + i·dx, y0 + j·dy) maps to source[j·nx + i]. Between nodes it is
/// bilinear; beyond the lattice the border cell is extended linearly.
struct CoordinateMap {
  int nx = 0;
  int ny = 0;
  double x0_m = 0.0;
  double y0_m = 0.0;
  double dx_m = 1.0;
  double dy_m = 1.0;
  std::vector<Vec2> source;

  /// The source coordinates of (x, y), and ∂(s, t)/∂(x, y) in `jacobian` when not null.
  Vec2 at(double x_m, double y_m, Mat2* jacobian = nullptr) const;
};

/// Throws InputError (field `what`) unless the lattice has at least 2 × 2 finite nodes and
/// positive finite spacing.
void validate_coordinate_map(const CoordinateMap& map, const std::string& what);

class MappedRasterTerrain : public Terrain {
 public:
  /// `source`: the DEM in its own coordinates (raster_grid.hpp's conventions, spacing in the
  /// CRS's units). `map_error_m`: the height error the map's interpolation may cause (see
  /// the file comment), reported as model_error_m(). Throws InputError (field `what`).
  MappedRasterTerrain(RasterGrid source, CoordinateMap map, double map_error_m,
                      const std::string& what = "terrain.dem.path");

  double height(double x_m, double y_m) const override;
  Vec2 gradient(double x_m, double y_m) const override;
  /// One map and one cell look-up for both (the MPC's clearance rows on a DEM).
  double height_and_gradient(double x_m, double y_m, Vec2& gradient_out) const override;
  double model_error_m() const override { return map_error_m_; }

  const RasterTerrain& source() const { return source_; }
  const CoordinateMap& map() const { return map_; }

 private:
  RasterTerrain source_;
  CoordinateMap map_;
  double map_error_m_ = 0.0;
};

/// The steepest slope of a raster's bilinear interpolation along each axis: the largest
/// |h(r, c+1) − h(r, c)|/cell_x and |h(r+1, c) − h(r, c)|/cell_y (height per CRS unit).
Vec2 max_axis_slopes(const RasterGrid& grid);

}  // namespace ridgeline::world
