// The terrain the trajectory optimizer sees on a DEM raster (issue 18): a C² surface with a
// measured bound.
//
// A raster's bilinear interpolation has a gradient that jumps at every cell edge; Ipopt's
// Newton steps on such rows stall (a 30 m UTM ridge stopped at the 800-iteration limit). The
// optimizer gets instead a C² upper envelope of the raster, with analytic gradient and Hessian:
//   1. the raster's bilinear surface is sampled at a quarter of its cell (so the spline
//      follows its kinks closely; half or the cell itself on rasters of over 250 000 or
//      1 000 000 cells, to bound memory) and interpolated by the uniform cubic B-spline through
//      those samples (natural end conditions, tensor product);
//   2. in every fine cell, the amount d by which the raster rises above that spline is
//      measured (3 × 3 points, plus the interpolation bound M·h²/8 between them, M the bound of
//      the spline's second derivative in the cell from its control points: inside a fine cell
//      the raster is linear along each axis);
//   3. a second B-spline whose control points are the largest d over the 4 × 4 cells each
//      control point weighs on is added: its value in a cell is a convex combination of
//      controls that are all ≥ that cell's d, so the sum never lies below the raster.
// The envelope therefore needs no margin of its own (model_error_m() is the raster model's);
// how far it stands above the raster at most (its conservatism, largest at cliffs) is
// measured too and reported. The dense check of a plan still uses the raster itself.
#pragma once

#include <algorithm>
#include <memory>
#include <vector>

#include "core/types.hpp"
#include "world/mapped_raster_terrain.hpp"
#include "world/raster_grid.hpp"
#include "world/terrain.hpp"

namespace ridgeline::world {

/// The uniform cubic B-spline through every sample of a raster of at least 2 × 2 samples
/// (raster_grid.hpp's cell-centre convention; InputError otherwise), in the raster's own
/// coordinates. Beyond the outer samples it is held constant
/// across the border (as RasterTerrain): value clamped, derivative across zero.
class BicubicSpline {
 public:
  explicit BicubicSpline(const RasterGrid& grid);
  /// Adds the B-spline whose control points are, for each, the largest of `cell_floor` over
  /// the cells it weighs on (cell_floor: (rows − 1) × (cols − 1), one value a cell, ≥ 0): the
  /// spline then rises by at least cell_floor[c] everywhere in cell c.
  void raise_by(const std::vector<double>& cell_floor);
  /// Bounds of |∂²S/∂s²| and |∂²S/∂t²| over cell (row, col), per unit² of the raster's
  /// coordinates: inside a cell they are convex combinations of the control points' second
  /// differences, so the largest of those (over the cell's 4 × 4 controls) bounds them.
  Vec2 second_derivative_bound(int row, int col) const;
  /// S(s, t), and its gradient and Hessian (per unit of the raster's coordinates) when asked.
  double evaluate(double s, double t, Vec2* gradient = nullptr,
                  Eigen::Matrix2d* hessian = nullptr) const;

 private:
  int rows_ = 0, cols_ = 0;
  double origin_s_ = 0.0, origin_t_ = 0.0, cell_s_ = 1.0, cell_t_ = 1.0;
  std::vector<double> control_;  ///< (rows + 2) × (cols + 2), one ring of end controls
};

/// A rectangle of the local frame (m) where the bound is measured.
struct PlanarBox {
  double x_min_m = 0.0, x_max_m = 0.0, y_min_m = 0.0, y_max_m = 0.0;
};

class SmoothRasterTerrain : public Terrain {
 public:
  /// The envelope of `grid`'s bilinear surface seen through `map` (null: the grid is in the
  /// local frame). `exact_model_error_m` is the raster model's own. `box` is where the
  /// conservatism is measured (the envelope holds over the whole grid).
  SmoothRasterTerrain(const RasterGrid& grid, const CoordinateMap* map, const PlanarBox& box,
                      double exact_model_error_m);

  double height(double x_m, double y_m) const override;
  Vec2 gradient(double x_m, double y_m) const override;
  Eigen::Matrix2d hessian(double x_m, double y_m) const override;
  /// The raster model's own error; plus raster_above_m() should the check ever find the
  /// raster above the envelope (it never has: the construction guarantees it).
  double model_error_m() const override {
    return exact_model_error_m_ + std::max(0.0, raster_above_m_);
  }

  /// How far the envelope stands above the raster at most, over the box (m): its
  /// conservatism (sampled at the fine cells' corners and centres).
  double envelope_above_m() const { return envelope_above_m_; }
  /// How far the raster rises above the envelope at most, where sampled (≤ 0 up to
  /// round-off: the construction guarantees it; tests check it).
  double raster_above_m() const { return raster_above_m_; }

 private:
  Vec2 source(double x_m, double y_m, Eigen::Matrix2d* jacobian) const;

  /// The construction on `grid` with a single row or column already doubled.
  SmoothRasterTerrain(const RasterGrid& grid, const CoordinateMap* map, const PlanarBox& box,
                      double exact_model_error_m, int);

  BicubicSpline spline_;
  bool mapped_ = false;
  CoordinateMap map_;
  double exact_model_error_m_ = 0.0;
  double envelope_above_m_ = 0.0;
  double raster_above_m_ = 0.0;
};

/// The optimizer's model of `exact` over `box`: a SmoothRasterTerrain when `exact` is a raster
/// (RasterTerrain or MappedRasterTerrain), else null (the analytic peak field is smooth
/// already).
std::shared_ptr<const Terrain> make_smooth_terrain(const Terrain& exact, const PlanarBox& box);

}  // namespace ridgeline::world
