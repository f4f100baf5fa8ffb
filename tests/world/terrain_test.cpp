#include "world/terrain.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"
#include "world/raster_grid.hpp"

namespace ridgeline::world {
namespace {

PeakTerrainConfig two_peaks(PeakCombination combination) {
  PeakTerrainConfig config;
  config.combination = combination;
  config.base_elevation_m = 12.5;
  config.peaks = {{500.0, 600.0, 250.0, 150.0, 200.0}, {900.0, 700.0, 180.0, 120.0, 90.0}};
  return config;
}

// Central finite difference of H; step 1e-3 m: truncation O(h²·H''') ~ 1e-9 and rounding
// ~ 1e-16·300 m / 1e-3 m ~ 3e-11, both far below the 1e-6 tolerance used with it.
Vec2 numeric_gradient(const Terrain& t, double x, double y, double step = 1e-3) {
  return Vec2((t.height(x + step, y) - t.height(x - step, y)) / (2 * step),
              (t.height(x, y + step) - t.height(x, y - step)) / (2 * step));
}

TEST(PeakTerrainTest, HeightsAtKnownPointsFollowEq12) {
  const PeakTerrain max_terrain(two_peaks(PeakCombination::kMax));
  const PeakTerrain sum_terrain(two_peaks(PeakCombination::kSum));
  // At the first peak's centre its term is h = 250; the second contributes
  // 180·exp(−(400/120)² − (100/90)²) ≈ 180·exp(−12.346) ≈ 7.77e-4 m.
  const double second = 180.0 * std::exp(-std::pow(400.0 / 120.0, 2) - std::pow(100.0 / 90.0, 2));
  EXPECT_NEAR(max_terrain.height(500, 600), 12.5 + 250.0, 1e-12);
  EXPECT_NEAR(sum_terrain.height(500, 600), 12.5 + 250.0 + second, 1e-12);
  // One sigma away along x: exp(−1).
  EXPECT_NEAR(max_terrain.height(650, 600), 12.5 + 250.0 * std::exp(-1.0), 1e-12);
  // Far away only the base is left (exp(−(10⁴/150)²) underflows to 0).
  EXPECT_DOUBLE_EQ(max_terrain.height(1e4, 1e4), 12.5);
  EXPECT_DOUBLE_EQ(sum_terrain.height(1e4, 1e4), 12.5);
  // No peaks: the flat base plane.
  PeakTerrainConfig flat;
  flat.base_elevation_m = 3.0;
  const PeakTerrain flat_terrain(flat);
  EXPECT_DOUBLE_EQ(flat_terrain.height(1, 2), 3.0);
  EXPECT_EQ(flat_terrain.gradient(1, 2), Vec2::Zero());
}

TEST(PeakTerrainTest, GradientMatchesCentralDifferencesForBothVariants) {
  Rng rng(42);
  for (const auto combination : {PeakCombination::kMax, PeakCombination::kSum}) {
    const PeakTerrain terrain(two_peaks(combination));
    for (int k = 0; k < 200; ++k) {
      const double x = rng.uniform(200, 1200);
      const double y = rng.uniform(300, 1000);
      if (combination == PeakCombination::kMax) {
        // Skip points within a finite-difference step of the kink where the peaks are equal.
        const auto term = [](const Peak& p, double px, double py) {
          return p.height_m * std::exp(-std::pow((px - p.x_m) / p.sigma_x_m, 2) -
                                       std::pow((py - p.y_m) / p.sigma_y_m, 2));
        };
        const auto& peaks = terrain.config().peaks;
        if (std::abs(term(peaks[0], x, y) - term(peaks[1], x, y)) < 1e-2) continue;
      }
      const Vec2 analytic = terrain.gradient(x, y);
      const Vec2 numeric = numeric_gradient(terrain, x, y);
      EXPECT_NEAR(analytic.x(), numeric.x(), 1e-6) << "at " << x << ", " << y;
      EXPECT_NEAR(analytic.y(), numeric.y(), 1e-6) << "at " << x << ", " << y;
    }
  }
}

// The max field picks its dominant peak by ln h_i − q_i (one exp a query); a brute-force
// reference takes every peak's value h_i·exp(−q_i) and the largest (lowest index on a tie).
// Away from ties the two pick the same peak and so agree bit for bit; 12 random peaks of very
// different heights and widths, points spread over and beyond them (including where every term
// underflows to 0).
TEST(PeakTerrainTest, MaxFieldMatchesBruteForceOverAllPeaks) {
  Rng rng(17);
  PeakTerrainConfig config;
  config.combination = PeakCombination::kMax;
  config.base_elevation_m = -4.0;
  for (int i = 0; i < 12; ++i)
    config.peaks.push_back({rng.uniform(0, 2000), rng.uniform(0, 2000), rng.uniform(1, 400),
                            rng.uniform(5, 400), rng.uniform(5, 400)});
  const PeakTerrain terrain(config);
  int compared = 0;
  for (int k = 0; k < 5000; ++k) {
    const double x = rng.uniform(-3000, 5000);
    const double y = rng.uniform(-3000, 5000);
    double best = -1.0;
    double second = -1.0;
    const Peak* dominant = nullptr;
    for (const Peak& p : config.peaks) {
      const double dx = (x - p.x_m) / p.sigma_x_m;
      const double dy = (y - p.y_m) / p.sigma_y_m;
      const double value = p.height_m * std::exp(-(dx * dx + dy * dy));
      if (value > best) {
        second = best;
        best = value;
        dominant = &p;
      } else {
        second = std::max(second, value);
      }
    }
    const Vec2 gradient(-2.0 * best * (x - dominant->x_m) / std::pow(dominant->sigma_x_m, 2),
                        -2.0 * best * (y - dominant->y_m) / std::pow(dominant->sigma_y_m, 2));
    // A near-tie may pick the other peak (same height to round-off, another gradient).
    if (best > 0.0 && best - second < 1e-12 * best) continue;
    EXPECT_EQ(terrain.height(x, y), config.base_elevation_m + best) << x << ", " << y;
    EXPECT_EQ(terrain.gradient(x, y), gradient) << x << ", " << y;
    ++compared;
  }
  EXPECT_GT(compared, 4900);
}

// Two peaks of the same height and width on either side of the query point tie exactly; the
// max field must take the lower index, wherever the two sit among the others (in the same
// lane, in different lanes or passes of the four-at-a-time search, in its scalar tail), which
// the gradient's sign shows. The other peaks are far away and low.
TEST(PeakTerrainTest, MaxFieldTakesTheLowerIndexOnAnExactTie) {
  const double x = 1000.0, y = 1000.0, d = 30.0;
  int compared = 0;
  for (const int n : {2, 7, 8, 9, 12, 13, 17}) {
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        if (i == j) continue;
        PeakTerrainConfig config;
        config.combination = PeakCombination::kMax;
        for (int k = 0; k < n; ++k) config.peaks.push_back({5000.0 + 100 * k, -4000.0, 1.0, 50, 50});
        config.peaks[static_cast<std::size_t>(i)] = {x - d, y, 200.0, 100.0, 80.0};  // left
        config.peaks[static_cast<std::size_t>(j)] = {x + d, y, 200.0, 100.0, 80.0};  // right
        const PeakTerrain terrain(config);
        // The left peak's slope at the point falls to +x (negative), the right one's rises.
        const double slope = terrain.gradient(x, y).x();
        EXPECT_EQ(slope < 0.0, i < j) << n << " " << i << " " << j;
        EXPECT_NE(slope, 0.0);
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 600);
}

// height_and_gradient is what the MPC's clearance rows read: it must equal height() and
// gradient() bit for bit, for both combinations, for more peaks than one batch of the
// dominant-peak search (32), on a raster (the default of the interface) and with no peaks.
TEST(PeakTerrainTest, HeightAndGradientEqualTheSeparateQueries) {
  Rng rng(23);
  PeakTerrainConfig many;
  many.base_elevation_m = 7.0;
  for (int i = 0; i < 70; ++i)
    many.peaks.push_back({rng.uniform(0, 3000), rng.uniform(0, 3000), rng.uniform(1, 400),
                          rng.uniform(20, 400), rng.uniform(20, 400)});
  std::vector<std::unique_ptr<Terrain>> terrains;
  for (const auto combination : {PeakCombination::kMax, PeakCombination::kSum}) {
    many.combination = combination;
    terrains.push_back(std::make_unique<PeakTerrain>(many));
  }
  terrains.push_back(std::make_unique<PeakTerrain>(PeakTerrainConfig{}));
  terrains.push_back(std::make_unique<RasterTerrain>(
      sample_terrain(*terrains.front(), 30, 30, Vec2(0, 0), Vec2(100, 100))));
  int with_slope = 0;
  for (const auto& terrain : terrains) {
    for (int k = 0; k < 2000; ++k) {
      const double x = rng.uniform(-500, 3500);
      const double y = rng.uniform(-500, 3500);
      Vec2 g(1.0, 1.0);
      const double h = terrain->height_and_gradient(x, y, g);
      EXPECT_EQ(h, terrain->height(x, y)) << x << ", " << y;
      EXPECT_EQ(g, terrain->gradient(x, y)) << x << ", " << y;
      with_slope += g.norm() > 1e-3 ? 1 : 0;
    }
  }
  EXPECT_GT(with_slope, 4000);  // the peaks' flanks, not only the flat base
}

// heights_and_gradients is how the MPC's step reads the terrain at its Np positions: each
// entry must be height_and_gradient's bit for bit, for 1 to 70 peaks (the four-position lanes
// and the tail of one to three), both combinations, no peaks and a raster (the interface's
// default); a NaN position gives NaN in both; the max field's lower index on an exact tie
// holds in every lane. Spans of the wrong size are refused.
TEST(PeakTerrainTest, BatchEqualsHeightAndGradientBitForBit) {
  Rng rng(29);
  std::vector<std::unique_ptr<Terrain>> terrains;
  for (const int n : {1, 3, 7, 8, 9, 70}) {
    PeakTerrainConfig config;
    config.base_elevation_m = 3.0;
    for (int i = 0; i < n; ++i)
      config.peaks.push_back({rng.uniform(0, 2000), rng.uniform(0, 2000), rng.uniform(1, 400),
                              rng.uniform(20, 400), rng.uniform(20, 400)});
    for (const auto combination : {PeakCombination::kMax, PeakCombination::kSum}) {
      config.combination = combination;
      terrains.push_back(std::make_unique<PeakTerrain>(config));
    }
  }
  // Two equal peaks either side of (1000, 1000), among far low ones: an exact tie there.
  PeakTerrainConfig tie;
  for (int k = 0; k < 9; ++k) tie.peaks.push_back({5000.0 + 100 * k, -4000.0, 1.0, 50, 50});
  tie.peaks[2] = {970.0, 1000.0, 200.0, 100.0, 80.0};
  tie.peaks[6] = {1030.0, 1000.0, 200.0, 100.0, 80.0};
  terrains.push_back(std::make_unique<PeakTerrain>(tie));
  terrains.push_back(std::make_unique<PeakTerrain>(PeakTerrainConfig{}));
  terrains.push_back(std::make_unique<RasterTerrain>(
      sample_terrain(*terrains.front(), 30, 30, Vec2(0, 0), Vec2(100, 100))));
  for (const int count : {1, 4, 37, 40}) {
    Eigen::MatrixXd positions(3, count);
    for (int j = 0; j < count; ++j)
      positions.col(j) = Vec3(rng.uniform(-500, 2500), rng.uniform(-500, 2500), 100.0);
    if (count >= 37) {
      positions.col(5) = Vec3(1000.0, 1000.0, 0.0);  // the tie, in a lane
      positions.col(count - 2) = Vec3(1000.0, 1000.0, 0.0);  // and in the tail
      positions(0, 9) = std::numeric_limits<double>::quiet_NaN();
    }
    for (const auto& terrain : terrains) {
      std::vector<double> heights(static_cast<std::size_t>(count), -1.0);
      std::vector<Vec2> gradients(static_cast<std::size_t>(count), Vec2(7.0, 7.0));
      terrain->heights_and_gradients(positions, heights, gradients);
      for (int j = 0; j < count; ++j) {
        Vec2 g;
        const double h = terrain->height_and_gradient(positions(0, j), positions(1, j), g);
        const auto k = static_cast<std::size_t>(j);
        if (std::isnan(h)) {
          EXPECT_TRUE(std::isnan(heights[k])) << count << " " << j;
          continue;
        }
        EXPECT_EQ(heights[k], h) << count << " " << j;
        EXPECT_EQ(gradients[k], g) << count << " " << j;
      }
    }
  }
  // The tie's lower index (the left peak, sloping down to +x) in a batch of eight.
  const PeakTerrain tied(tie);
  Eigen::MatrixXd at_tie = Eigen::MatrixXd::Constant(2, 8, 1000.0);
  std::vector<double> heights(8);
  std::vector<Vec2> gradients(8);
  tied.heights_and_gradients(at_tie, heights, gradients);
  for (const Vec2& g : gradients) EXPECT_LT(g.x(), 0.0);
  std::vector<double> short_heights(7);
  EXPECT_THROW(tied.heights_and_gradients(at_tie, short_heights, gradients), std::invalid_argument);
  EXPECT_THROW(tied.heights_and_gradients(Eigen::MatrixXd(1, 8), heights, gradients),
               std::invalid_argument);
}

TEST(PeakTerrainTest, RejectsBadConfigNamingTheField) {
  PeakTerrainConfig config = two_peaks(PeakCombination::kMax);
  config.peaks.resize(4, config.peaks[0]);
  config.peaks[3].sigma_x_m = 0.0;
  try {
    PeakTerrain terrain(config);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.peaks[3].sigma_x_m");
    EXPECT_NE(e.reason().find("> 0"), std::string::npos) << e.reason();
  }
  config.peaks[3].sigma_x_m = 10.0;
  config.peaks[1].height_m = std::numeric_limits<double>::quiet_NaN();
  try {
    PeakTerrain terrain(config);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "terrain.peaks[1].height_m");
  }
  config.peaks[1].height_m = 10.0;
  config.peaks[2].y_m = std::numeric_limits<double>::infinity();
  EXPECT_THROW(PeakTerrain{config}, InputError);
  config.peaks[2].y_m = 0.0;
  config.model_error_m = -1.0;
  EXPECT_THROW(PeakTerrain{config}, InputError);
}

RasterGrid plane_grid(double a, double b, double c) {
  RasterGrid grid;
  grid.rows = 5;
  grid.cols = 7;
  grid.origin_x_m = 100.0;
  grid.origin_y_m = -50.0;
  grid.cell_x_m = 30.0;
  grid.cell_y_m = 20.0;
  grid.heights_m.resize(35);
  for (int r = 0; r < grid.rows; ++r) {
    for (int col = 0; col < grid.cols; ++col) {
      grid.at(r, col) = a * grid.x_of_col(col) + b * grid.y_of_row(r) + c;
    }
  }
  return grid;
}

TEST(RasterTerrainTest, BilinearIsExactOnAPlane) {
  // Bilinear interpolation reproduces any affine function; the only error is rounding.
  const double a = 0.3, b = -0.7, c = 40.0;
  const RasterTerrain terrain(plane_grid(a, b, c));
  Rng rng(7);
  for (int k = 0; k < 100; ++k) {
    const double x = rng.uniform(100.0, 100.0 + 6 * 30.0);
    const double y = rng.uniform(-50.0, -50.0 + 4 * 20.0);
    EXPECT_NEAR(terrain.height(x, y), a * x + b * y + c, 1e-9);
    EXPECT_NEAR(terrain.gradient(x, y).x(), a, 1e-12);
    EXPECT_NEAR(terrain.gradient(x, y).y(), b, 1e-12);
  }
  // Cell centres return the samples exactly, including the four corners.
  const RasterGrid& grid = terrain.grid();
  EXPECT_DOUBLE_EQ(terrain.height(grid.x_of_col(0), grid.y_of_row(0)), grid.at(0, 0));
  EXPECT_DOUBLE_EQ(terrain.height(grid.x_of_col(6), grid.y_of_row(4)), grid.at(4, 6));
  EXPECT_DOUBLE_EQ(terrain.height(grid.x_of_col(3), grid.y_of_row(2)), grid.at(2, 3));
}

TEST(RasterTerrainTest, PointsOutsideClampToTheBorder) {
  const double a = 0.3, b = -0.7, c = 40.0;
  const RasterTerrain terrain(plane_grid(a, b, c));
  // West of the grid at y inside: the west border's value, no x slope.
  EXPECT_NEAR(terrain.height(0.0, -10.0), a * 100.0 + b * -10.0 + c, 1e-9);
  EXPECT_EQ(terrain.gradient(0.0, -10.0).x(), 0.0);
  EXPECT_NEAR(terrain.gradient(0.0, -10.0).y(), b, 1e-12);
  // North-east beyond both borders: the corner value, flat.
  EXPECT_NEAR(terrain.height(1e6, 1e6), a * 280.0 + b * 30.0 + c, 1e-9);
  EXPECT_EQ(terrain.gradient(1e6, 1e6), Vec2::Zero());
}

TEST(RasterTerrainTest, GradientMatchesCentralDifferencesInsideCells) {
  // A raster of a curved field: bilinear patches are not planes, so the gradient varies
  // inside a cell; compare away from cell edges, where H is smooth.
  PeakTerrainConfig config = two_peaks(PeakCombination::kSum);
  const PeakTerrain peaks(config);
  const RasterTerrain terrain(sample_terrain(peaks, 40, 50, Vec2(0.0, 0.0), Vec2(25.0, 30.0)));
  Rng rng(3);
  for (int k = 0; k < 200; ++k) {
    const double col = std::floor(rng.uniform(0, 49)) + rng.uniform(0.05, 0.95);
    const double row = std::floor(rng.uniform(0, 39)) + rng.uniform(0.05, 0.95);
    const double x = col * 25.0, y = row * 30.0;
    const Vec2 analytic = terrain.gradient(x, y);
    const Vec2 numeric = numeric_gradient(terrain, x, y);
    EXPECT_NEAR(analytic.x(), numeric.x(), 1e-6);
    EXPECT_NEAR(analytic.y(), numeric.y(), 1e-6);
  }
}

TEST(RasterTerrainTest, SampledPeakTerrainInterpolatesCloseToTheField) {
  // Bilinear error of a C² field: |e| <= (Δx²·max|H_xx| + Δy²·max|H_yy|)/8. For a peak
  // |∂²(h·e)/∂x²| <= 2h/a² (at its centre), and the `sum` field's curvature is at most the sum
  // of its peaks'. (The `max` field has kinks where bilinear error is not bounded this way.)
  const PeakTerrainConfig config = two_peaks(PeakCombination::kSum);
  const PeakTerrain peaks(config);
  const double cell_m = 10.0;
  double hxx = 0.0, hyy = 0.0;
  for (const Peak& p : config.peaks) {
    hxx += 2.0 * p.height_m / (p.sigma_x_m * p.sigma_x_m);
    hyy += 2.0 * p.height_m / (p.sigma_y_m * p.sigma_y_m);
  }
  const double bound_m = cell_m * cell_m * (hxx + hyy) / 8.0;
  const RasterTerrain terrain(
      sample_terrain(peaks, 121, 151, Vec2(0.0, 0.0), Vec2(cell_m, cell_m)));
  Rng rng(11);
  double worst = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double x = rng.uniform(0, 1500), y = rng.uniform(0, 1200);
    worst = std::max(worst, std::abs(terrain.height(x, y) - peaks.height(x, y)));
  }
  EXPECT_LE(worst, bound_m);
  // The bound is attained only at the peaks' centres with both axes at mid-cell; the
  // observed error should be a sizeable fraction of it, i.e. the check is not vacuous.
  EXPECT_GT(worst, 0.1 * bound_m);
}

TEST(RasterTerrainTest, RejectsBadGrids) {
  RasterGrid grid = plane_grid(0, 0, 1);
  grid.heights_m.pop_back();
  EXPECT_THROW(RasterTerrain{grid}, InputError);
  grid = plane_grid(0, 0, 1);
  grid.cell_y_m = 0.0;
  EXPECT_THROW(RasterTerrain{grid}, InputError);
  grid = plane_grid(0, 0, 1);
  grid.heights_m[3] = std::numeric_limits<double>::quiet_NaN();
  try {
    RasterTerrain terrain(grid, 0.0, "dem.tif");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "dem.tif");
    EXPECT_NE(e.reason().find("row 0, col 3"), std::string::npos) << e.reason();
  }
}

TEST(RasterTerrainTest, SingleRowGridIsConstantAcrossRows) {
  RasterGrid grid;
  grid.rows = 1;
  grid.cols = 3;
  grid.heights_m = {0.0, 10.0, 30.0};
  const RasterTerrain terrain(grid);
  EXPECT_DOUBLE_EQ(terrain.height(0.5, 123.0), 5.0);
  EXPECT_DOUBLE_EQ(terrain.gradient(1.5, -4.0).x(), 20.0);
  EXPECT_DOUBLE_EQ(terrain.gradient(1.5, -4.0).y(), 0.0);
}

}  // namespace
}  // namespace ridgeline::world
