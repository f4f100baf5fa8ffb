#include "core/sin_cos.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "core/types.hpp"

namespace ridgeline {
namespace {

// |value − exact| in units of the last place of the double nearest `exact` on the error's side
// (below a power of two the spacing is half the one above; long double's sin and cos carry
// eleven more bits than a double, a reference well below the errors measured).
double ulps(double value, long double exact) {
  const double nearest = static_cast<double>(exact);
  const double toward = static_cast<long double>(value) > exact
                            ? std::numeric_limits<double>::infinity()
                            : -std::numeric_limits<double>::infinity();
  const double ulp = std::abs(std::nextafter(nearest, toward) - nearest);
  return static_cast<double>(std::abs(static_cast<long double>(value) - exact)) / ulp;
}

struct WorstError {
  double sin_ulps = 0.0, cos_ulps = 0.0;
};

WorstError worst_error(const std::vector<double>& x) {
  std::vector<double> s(x.size()), c(x.size());
  sin_cos(x.data(), s.data(), c.data(), static_cast<int>(x.size()));
  WorstError w;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const long double xl = x[i];
    w.sin_ulps = std::max(w.sin_ulps, ulps(s[i], std::sin(xl)));
    w.cos_ulps = std::max(w.cos_ulps, ulps(c[i], std::cos(xl)));
  }
  return w;
}

// Within libmvec's documented 4 ulp of the exact values (measured on this machine: 3.4 ulp at
// most; libm's scalar path, without AVX2, is within 1): uniformly over ranges of angles up to
// those of the wind's modes, and next to the multiples of π/2 where one of the two is tiny and
// an error of the argument's reduction would show in full.
TEST(SinCos, WithinFourUlpOfTheExactValues) {
  std::mt19937_64 rng(7);
  for (const double range : {kPi / 4, 4.0, 100.0, 1e4, 1e5}) {
    std::uniform_real_distribution<double> angle(-range, range);
    std::vector<double> x(100000);
    for (double& v : x) v = angle(rng);
    const WorstError w = worst_error(x);
    EXPECT_LE(w.sin_ulps, 4.0) << "range " << range;
    EXPECT_LE(w.cos_ulps, 4.0) << "range " << range;
  }
  std::vector<double> near_axes;
  std::uniform_real_distribution<double> offset(-1e-6, 1e-6);
  for (int k = -60000; k <= 60000; k += 7) {
    const double axis = static_cast<double>(k * (std::numbers::pi_v<long double> / 2));
    near_axes.push_back(axis);
    near_axes.push_back(axis + offset(rng));
    near_axes.push_back(std::nextafter(axis, 0.0));
  }
  const WorstError w = worst_error(near_axes);
  EXPECT_LE(w.sin_ulps, 4.0);
  EXPECT_LE(w.cos_ulps, 4.0);
}

// Signed zeros, tiny angles, NaN and ±∞ (NaN out), and large angles.
TEST(SinCos, ZerosAndNonFiniteAndLargeAngles) {
  const double inf = std::numeric_limits<double>::infinity();
  const double x[] = {0.0, -0.0, 1e-300, -5e-324, std::nan(""), inf, -inf, 2e5, 1.0, 1e15, 3.0};
  constexpr int n = sizeof x / sizeof x[0];
  double s[n], c[n];
  sin_cos(x, s, c, n);
  EXPECT_EQ(s[0], 0.0);
  EXPECT_FALSE(std::signbit(s[0]));
  EXPECT_EQ(s[1], 0.0);
  EXPECT_TRUE(std::signbit(s[1]));  // sin(−0) = −0
  EXPECT_EQ(c[0], 1.0);
  EXPECT_EQ(c[1], 1.0);
  EXPECT_EQ(s[2], 1e-300);
  EXPECT_EQ(c[2], 1.0);
  EXPECT_EQ(s[3], -5e-324);
  for (int i = 4; i <= 6; ++i) {
    EXPECT_TRUE(std::isnan(s[i])) << x[i];
    EXPECT_TRUE(std::isnan(c[i])) << x[i];
  }
  for (const int i : {7, 8, 9, 10}) {
    EXPECT_NEAR(s[i], std::sin(x[i]), 1e-15) << x[i];
    EXPECT_NEAR(c[i], std::cos(x[i]), 1e-15) << x[i];
  }
}

// Any count: the one to three angles after the last group of four give the values they give
// inside a group, and nothing past n is written.
TEST(SinCos, EveryCountGivesTheSameValues) {
  std::vector<double> x(9);
  for (int i = 0; i < 9; ++i) x[i] = 0.37 * i - 1.1;
  std::vector<double> s_all(9), c_all(9);
  sin_cos(x.data(), s_all.data(), c_all.data(), 8);
  for (int n = 0; n <= 9; ++n) {
    std::vector<double> s(10, 42.0), c(10, 42.0);
    sin_cos(x.data(), s.data(), c.data(), n);
    for (int i = 0; i < n; ++i) {
      if (i < 8) {
        EXPECT_EQ(s[i], s_all[i]) << n << " " << i;
        EXPECT_EQ(c[i], c_all[i]) << n << " " << i;
      }
      EXPECT_NEAR(s[i] * s[i] + c[i] * c[i], 1.0, 1e-15);  // two errors of 4 ulp
    }
    for (int i = n; i < 10; ++i) {
      EXPECT_EQ(s[i], 42.0);
      EXPECT_EQ(c[i], 42.0);
    }
  }
}

}  // namespace
}  // namespace ridgeline
