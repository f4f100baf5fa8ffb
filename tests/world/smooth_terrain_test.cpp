// The optimizer's terrain on a raster (issue 18, world/smooth_terrain.hpp): the B-spline
// interpolates its samples, its gradient and Hessian are the finite differences of its value
// and gradient, and the envelope built from it never lies below the raster (checked densely on
// rough random terrain, plain and through a coordinate map) while staying close to it where
// the raster is smooth.
#include "world/smooth_terrain.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.hpp"
#include "core/random.hpp"

namespace ridgeline::world {
namespace {

RasterGrid rough_grid(std::uint64_t seed, int rows, int cols, double cell) {
  Rng rng(seed);
  RasterGrid g;
  g.rows = rows;
  g.cols = cols;
  g.origin_x_m = -0.5 * cell * (cols - 1);
  g.origin_y_m = -0.5 * cell * (rows - 1);
  g.cell_x_m = cell;
  g.cell_y_m = 0.8 * cell;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)  // a ridge, waves and 40 m of noise: cliffs between cells
      g.heights_m.push_back(1000.0 + 300.0 * std::exp(-std::pow((c - cols / 2.0) / 2.0, 2)) +
                            60.0 * std::sin(0.9 * r) + rng.uniform(0.0, 40.0));
  return g;
}

TEST(BicubicSpline, InterpolatesTheSamplesAndItsDerivativesAreConsistent) {
  const RasterGrid g = rough_grid(3, 12, 15, 30.0);
  const BicubicSpline spline(g);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c)
      ASSERT_NEAR(spline.evaluate(g.x_of_col(c), g.y_of_row(r)), g.at(r, c), 1e-9);
  Rng rng(5);
  for (int k = 0; k < 300; ++k) {
    const double s = rng.uniform(g.x_of_col(0.2), g.x_of_col(g.cols - 1.2));
    const double t = rng.uniform(g.y_of_row(0.2), g.y_of_row(g.rows - 1.2));
    Vec2 grad;
    Eigen::Matrix2d hess;
    spline.evaluate(s, t, &grad, &hess);
    const double h = 1e-4;
    const Vec2 fd((spline.evaluate(s + h, t) - spline.evaluate(s - h, t)) / (2 * h),
                  (spline.evaluate(s, t + h) - spline.evaluate(s, t - h)) / (2 * h));
    ASSERT_LT((grad - fd).norm(), 1e-5 * (1.0 + grad.norm()));
    Vec2 gx1, gx0, gy1, gy0;
    spline.evaluate(s + h, t, &gx1);
    spline.evaluate(s - h, t, &gx0);
    spline.evaluate(s, t + h, &gy1);
    spline.evaluate(s, t - h, &gy0);
    Eigen::Matrix2d fdh;
    fdh.col(0) = (gx1 - gx0) / (2 * h);
    fdh.col(1) = (gy1 - gy0) / (2 * h);
    ASSERT_LT((hess - fdh).norm(), 1e-4 * (1.0 + hess.norm()));
  }
}

TEST(SmoothRasterTerrain, TheEnvelopeNeverLiesBelowTheRaster) {
  for (const std::uint64_t seed : {1, 2, 3}) {
    const RasterGrid g = rough_grid(seed, 20, 24, 30.0);
    const RasterTerrain raster(g);
    const PlanarBox box{g.x_of_col(0), g.x_of_col(g.cols - 1), g.y_of_row(0),
                        g.y_of_row(g.rows - 1)};
    const auto smooth = make_smooth_terrain(raster, box);
    ASSERT_NE(smooth, nullptr);
    const auto& envelope = dynamic_cast<const SmoothRasterTerrain&>(*smooth);
    EXPECT_LE(envelope.raster_above_m(), 1e-9);
    double worst = -1e9, above = 0.0;
    Rng rng(seed + 100);
    for (int k = 0; k < 200000; ++k) {
      const double x = rng.uniform(box.x_min_m - 20.0, box.x_max_m + 20.0);
      const double y = rng.uniform(box.y_min_m - 20.0, box.y_max_m + 20.0);
      const double d = raster.height(x, y) - smooth->height(x, y);
      worst = std::max(worst, d);
      above = std::max(above, -d);
    }
    EXPECT_LE(worst, 1e-9) << seed;
    // The conservatism reported is the one found, give or take the sampling.
    EXPECT_NEAR(above, envelope.envelope_above_m(), 0.1 * envelope.envelope_above_m() + 0.5);
    // Gradient and Hessian: those of the model, also through the terrain interface.
    const Vec2 g0 = smooth->gradient(10.0, 5.0);
    const double h = 1e-3;
    EXPECT_NEAR(g0.x(), (smooth->height(10.0 + h, 5.0) - smooth->height(10.0 - h, 5.0)) / (2 * h),
                1e-4);
    EXPECT_NEAR(g0.y(), (smooth->height(10.0, 5.0 + h) - smooth->height(10.0, 5.0 - h)) / (2 * h),
                1e-4);
  }
}

TEST(SmoothRasterTerrain, OnSmoothGroundTheEnvelopeHugsTheRaster) {
  RasterGrid g;
  g.rows = 30;
  g.cols = 30;
  g.cell_x_m = g.cell_y_m = 30.0;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c)
      g.heights_m.push_back(
          500.0 + 200.0 * std::exp(-(std::pow(c - 15.0, 2) + std::pow(r - 12.0, 2)) / 60.0));
  const RasterTerrain raster(g);
  const auto smooth = make_smooth_terrain(raster, {0.0, 870.0, 0.0, 870.0});
  const auto& envelope = dynamic_cast<const SmoothRasterTerrain&>(*smooth);
  EXPECT_LT(envelope.envelope_above_m(), 2.0);  // metres over a 200 m hill on 30 m cells
  EXPECT_LE(envelope.raster_above_m(), 1e-9);
}

TEST(SmoothRasterTerrain, ThroughACoordinateMapItIsTheEnvelopeOfTheMappedRaster) {
  const RasterGrid g = rough_grid(9, 20, 20, 1.0 / 1200.0);  // degrees
  CoordinateMap map;
  map.nx = map.ny = 6;
  map.x0_m = map.y0_m = -600.0;
  map.dx_m = map.dy_m = 240.0;
  for (int j = 0; j < map.ny; ++j)
    for (int i = 0; i < map.nx; ++i) {
      const double x = map.x0_m + i * map.dx_m, y = map.y0_m + j * map.dy_m;
      map.source.emplace_back((x - 0.01 * y) / 88700.0, (y + 0.01 * x) / 110950.0);
    }
  const MappedRasterTerrain exact(g, map, 0.0);
  const auto smooth = make_smooth_terrain(exact, {-500.0, 500.0, -500.0, 500.0});
  ASSERT_NE(smooth, nullptr);
  Rng rng(4);
  for (int k = 0; k < 50000; ++k) {
    const double x = rng.uniform(-500.0, 500.0), y = rng.uniform(-500.0, 500.0);
    ASSERT_LE(exact.height(x, y) - smooth->height(x, y), 1e-9) << x << ", " << y;
  }
  // Peaks have no envelope: they are smooth already.
  EXPECT_EQ(make_smooth_terrain(PeakTerrain(PeakTerrainConfig{}), {0, 1, 0, 1}), nullptr);
}

TEST(SmoothRasterTerrain, ASingleRowOrColumnRasterIsEnvelopedToo) {
  for (const bool one_row : {true, false}) {
    RasterGrid g;
    g.rows = one_row ? 1 : 12;
    g.cols = one_row ? 12 : 1;
    g.cell_x_m = g.cell_y_m = 25.0;
    for (int k = 0; k < 12; ++k) g.heights_m.push_back(300.0 + 40.0 * std::sin(1.3 * k));
    const RasterTerrain raster(g);
    const auto smooth = make_smooth_terrain(raster, {-50.0, 350.0, -50.0, 350.0});
    ASSERT_NE(smooth, nullptr);
    for (double x = -60.0; x <= 360.0; x += 3.7)
      for (double y = -60.0; y <= 360.0; y += 9.1) {
        const double h = smooth->height(x, y);
        ASSERT_TRUE(std::isfinite(h));
        ASSERT_LE(raster.height(x, y) - h, 1e-9) << x << ", " << y;
      }
  }
  RasterGrid single;
  single.rows = 1;
  single.cols = 3;
  single.heights_m = {1.0, 2.0, 3.0};
  EXPECT_THROW(BicubicSpline{single}, InputError);
}

}  // namespace
}  // namespace ridgeline::world
