#include "core/random.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/types.hpp"

namespace ridgeline {
namespace {

TEST(Rng, SameSeedSameSequenceDifferentSeedDifferentSequence) {
  Rng a(123), b(123), c(124);
  int differences = 0;
  for (int i = 0; i < 100; ++i) {
    const double x = a.normal(), y = b.normal(), z = c.normal();
    EXPECT_EQ(x, y);
    differences += (x != z);
  }
  EXPECT_GT(differences, 95);
}

TEST(Rng, UniformAndNormalMomentsMatch) {
  Rng rng(7);
  constexpr int kN = 200000;
  double sum_u = 0, sum_n = 0, sum_n2 = 0;
  for (int i = 0; i < kN; ++i) {
    const double u = rng.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum_u += u;
    const double n = rng.normal(2.0, 3.0);
    sum_n += n;
    sum_n2 += n * n;
  }
  const double mean_n = sum_n / kN;
  const double std_n = std::sqrt(sum_n2 / kN - mean_n * mean_n);
  // Standard errors: uniform mean 0.29/√N ≈ 6.5e-4; normal mean 3/√N ≈ 6.7e-3; normal std
  // 3/√(2N) ≈ 4.7e-3. Tolerances are five standard errors.
  EXPECT_NEAR(sum_u / kN, 0.5, 3.3e-3);
  EXPECT_NEAR(mean_n, 2.0, 3.4e-2);
  EXPECT_NEAR(std_n, 3.0, 2.4e-2);
}

TEST(Rng, DerivedSeedsAreDistinctPerStream) {
  EXPECT_NE(derive_seed(1, 0), derive_seed(1, 1));
  EXPECT_NE(derive_seed(1, 0), derive_seed(2, 0));
  EXPECT_EQ(derive_seed(5, 3), derive_seed(5, 3));
}

TEST(WrapAngle, MapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(wrap_angle(0.0), 0.0);
  EXPECT_NEAR(wrap_angle(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(-kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(2 * kPi + 0.5), 0.5, 1e-12);
  EXPECT_NEAR(wrap_angle(-2 * kPi - 0.5), -0.5, 1e-12);
  for (double a = -20; a < 20; a += 0.37) {
    const double w = wrap_angle(a);
    EXPECT_GT(w, -kPi);
    EXPECT_LE(w, kPi);
    EXPECT_NEAR(std::remainder(w - a, 2 * kPi), 0.0, 1e-9);
  }
}

// floor(f) clamped to [0, last] for every f, including those past the ends, the integers, the
// values just below them, and the ones std::floor could not cast (huge, infinite, NaN → 0).
TEST(SegmentIndex, IsTheClampedFloor) {
  for (const int last : {0, 1, 5, 38}) {
    for (double f = -3.0; f < last + 3.0; f += 0.125) {
      const double floor = std::clamp(std::floor(f), 0.0, static_cast<double>(last));
      EXPECT_EQ(segment_index(f, last), static_cast<int>(floor)) << f << " " << last;
      const double below = std::nextafter(f, -1e9);
      const double floor_below = std::clamp(std::floor(below), 0.0, static_cast<double>(last));
      EXPECT_EQ(segment_index(below, last), static_cast<int>(floor_below)) << below;
    }
    EXPECT_EQ(segment_index(1e300, last), last);
    EXPECT_EQ(segment_index(std::numeric_limits<double>::infinity(), last), last);
    EXPECT_EQ(segment_index(-std::numeric_limits<double>::infinity(), last), 0);
    EXPECT_EQ(segment_index(std::nan(""), last), 0);
  }
}

}  // namespace
}  // namespace ridgeline
