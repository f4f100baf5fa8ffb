// MappedRasterTerrain (issue 18): a DEM queried on its own pixels through a map of the local
// frame. With an affine map it is exactly the raster seen through that map; its gradient is the
// chain rule's (checked against finite differences inside cells); beyond the lattice the map
// extends linearly; bad maps are one error naming the field.
#include "world/mapped_raster_terrain.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/error.hpp"

namespace ridgeline::world {
namespace {

RasterGrid bumpy_grid() {
  RasterGrid g;
  g.rows = 30;
  g.cols = 40;
  g.origin_x_m = -113.02;  // degrees, as a DEM in EPSG:4326
  g.origin_y_m = 37.29;
  g.cell_x_m = g.cell_y_m = 1.0 / 1200.0;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c)
      g.heights_m.push_back(1500.0 + 80.0 * std::sin(0.7 * c) * std::cos(0.4 * r) + 5.0 * c);
  return g;
}

// An affine map from metres to degrees, rotated a little (meridian convergence).
Vec2 affine(double x, double y) {
  return Vec2(-113.0 + (x * 1.0 - y * 0.02) / 88700.0, 37.3 + (x * 0.02 + y * 1.0) / 110950.0);
}

CoordinateMap affine_map() {
  CoordinateMap m;
  m.nx = 9;
  m.ny = 7;
  m.x0_m = -800.0;
  m.y0_m = -600.0;
  m.dx_m = 200.0;
  m.dy_m = 200.0;
  for (int j = 0; j < m.ny; ++j)
    for (int i = 0; i < m.nx; ++i)
      m.source.push_back(affine(m.x0_m + i * m.dx_m, m.y0_m + j * m.dy_m));
  return m;
}

TEST(MappedRasterTerrain, AnAffineMapGivesTheRasterOnItsOwnPixels) {
  const RasterGrid grid = bumpy_grid();
  const RasterTerrain direct(grid);
  const MappedRasterTerrain mapped(grid, affine_map(), 0.0);
  for (double x = -900.0; x <= 900.0; x += 37.0)  // beyond the lattice too (extended map)
    for (double y = -700.0; y <= 700.0; y += 41.0) {
      const Vec2 s = affine(x, y);
      ASSERT_NEAR(mapped.height(x, y), direct.height(s.x(), s.y()), 1e-6) << x << ", " << y;
    }
}

TEST(MappedRasterTerrain, GradientIsTheChainRuleOfTheMapAndTheRaster) {
  const MappedRasterTerrain mapped(bumpy_grid(), affine_map(), 0.0);
  int checked = 0;
  for (double x = -700.0; x <= 700.0; x += 53.0)
    for (double y = -500.0; y <= 500.0; y += 47.0) {
      const double h = 1e-3;
      const Vec2 fd((mapped.height(x + h, y) - mapped.height(x - h, y)) / (2 * h),
                    (mapped.height(x, y + h) - mapped.height(x, y - h)) / (2 * h));
      const Vec2 g = mapped.gradient(x, y);
      // Within a cell H is smooth; a point within h of a cell edge may straddle a kink.
      if ((fd - g).norm() > 1e-4 * (1.0 + g.norm())) {
        const Vec2 a = mapped.gradient(x + 2 * h, y + 2 * h),
                   b = mapped.gradient(x - 2 * h, y - 2 * h);
        EXPECT_GT((a - b).norm(), 1e-6) << "mismatch away from a cell edge at " << x << ", " << y;
        continue;
      }
      ++checked;
    }
  EXPECT_GT(checked, 500);
}

// The MPC's clearance rows on a DEM read height_and_gradient (one map and one cell look-up for
// both): it must equal height() and gradient() bit for bit, inside the lattice, beyond it and
// on cell edges, and so must the batch of the Np positions of a step.
TEST(MappedRasterTerrain, HeightAndGradientEqualTheSeparateQueries) {
  const MappedRasterTerrain mapped(bumpy_grid(), affine_map(), 0.0);
  Eigen::MatrixXd positions(3, 0);
  for (double x = -900.0; x <= 900.0; x += 31.0)
    for (double y = -700.0; y <= 700.0; y += 29.0) {
      Vec2 g(9.0, 9.0);
      const double h = mapped.height_and_gradient(x, y, g);
      EXPECT_EQ(h, mapped.height(x, y)) << x << ", " << y;
      EXPECT_EQ(g, mapped.gradient(x, y)) << x << ", " << y;
      positions.conservativeResize(3, positions.cols() + 1);
      positions.col(positions.cols() - 1) = Vec3(x, y, 0.0);
    }
  std::vector<double> heights(static_cast<std::size_t>(positions.cols()));
  std::vector<Vec2> gradients(heights.size());
  mapped.heights_and_gradients(positions, heights, gradients);
  for (Eigen::Index j = 0; j < positions.cols(); ++j) {
    const auto k = static_cast<std::size_t>(j);
    EXPECT_EQ(heights[k], mapped.height(positions(0, j), positions(1, j)));
    EXPECT_EQ(gradients[k], mapped.gradient(positions(0, j), positions(1, j)));
  }
}

TEST(MappedRasterTerrain, BadMapsAreOneErrorNamingTheField) {
  CoordinateMap m = affine_map();
  m.source[5].x() = std::nan("");
  EXPECT_THROW(MappedRasterTerrain(bumpy_grid(), m, 0.0, "terrain.dem.path"), InputError);
  m = affine_map();
  m.nx = 1;
  try {
    MappedRasterTerrain(bumpy_grid(), m, 0.0, "terrain.dem.path");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.dem.path");
  }
  EXPECT_THROW(MappedRasterTerrain(bumpy_grid(), affine_map(), -1.0), InputError);
}

TEST(MappedRasterTerrain, MaxAxisSlopesAreTheSteepestCellDifferences) {
  RasterGrid g;
  g.rows = 2;
  g.cols = 3;
  g.cell_x_m = 2.0;
  g.cell_y_m = 4.0;
  g.heights_m = {0.0, 1.0, 7.0, 2.0, 2.0, 3.0};
  const Vec2 s = max_axis_slopes(g);
  EXPECT_DOUBLE_EQ(s.x(), 3.0);  // |7 − 1|/2
  EXPECT_DOUBLE_EQ(s.y(), 1.0);  // |7 − 3|/4
}

}  // namespace
}  // namespace ridgeline::world
