// The sphere rows' vector code against the scalar Vec3 expressions it replaced in the tracker:
// the same values bit for bit (distances, normals, bounds, which rows are active).
#include "mpc/sphere_rows.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace ridgeline::mpc {
namespace {

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

struct Horizon {
  std::vector<double> x, y, z;
  explicit Horizon(int n) : x(n), y(n), z(n) {}
  HorizonPoints points() const { return {x.data(), y.data(), z.data()}; }
  Vec3 at(int j) const { return {x[j], y[j], z[j]}; }
};

TEST(SphereRows, EqualTheVec3ExpressionsBitForBit) {
  std::mt19937 rng(20261127);
  std::uniform_real_distribution<double> coordinate(-400.0, 400.0), unit(0.0, 1.0);
  int active_rows = 0, inactive_rows = 0;
  // Horizons of every length up to 13 (the lanes past the last multiple of four) and the
  // default 40; with and without margins and a time window.
  for (int n : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 40, 41}) {
    for (int variant = 0; variant < 4; ++variant) {
      Horizon nominal(n), centre(n);
      std::vector<double> margins(n);
      for (int j = 0; j < n; ++j) {
        nominal.x[j] = coordinate(rng);
        nominal.y[j] = coordinate(rng);
        nominal.z[j] = 0.3 * coordinate(rng);
        // Centres near the nominal, so that both sides of the activation test occur.
        centre.x[j] = nominal.x[j] + 0.25 * coordinate(rng);
        centre.y[j] = nominal.y[j] + 0.25 * coordinate(rng);
        centre.z[j] = nominal.z[j] + 0.1 * coordinate(rng);
        margins[j] = 3.0 * unit(rng);
      }
      if (n >= 3) {  // a nominal on its centre, and one not finite
        centre.x[1] = nominal.x[1];
        centre.y[1] = nominal.y[1];
        centre.z[1] = nominal.z[1];
        nominal.y[2] = std::numeric_limits<double>::quiet_NaN();
      }
      SphereSpec sphere;
      sphere.centres = centre.points();
      sphere.margins = variant % 2 == 0 ? margins.data() : nullptr;
      sphere.required_m = 20.0 + 30.0 * unit(rng);
      sphere.activation_m = 60.0;
      sphere.windowed = variant >= 2;
      sphere.t_s = 12.34;
      sphere.dt_s = 0.1;
      sphere.from_s = sphere.t_s + 0.1 * n / 4.0;  // the window opens and closes inside
      sphere.to_s = sphere.t_s + 0.1 * (3 * n) / 4.0;
      std::vector<double> distance(n), nx(n), ny(n), nz(n), bound(n);
      std::vector<std::int64_t> active(n, 7);
      sphere_rows(nominal.points(), sphere, n,
                  {distance.data(), nx.data(), ny.data(), nz.data(), bound.data(), active.data()});
      for (int j = 0; j < n; ++j) {
        SCOPED_TRACE(testing::Message() << "n " << n << " variant " << variant << " step " << j);
        // The tracker's scalar code before the vector loops.
        const Vec3 c = centre.at(j);
        const Vec3 diff = nominal.at(j) - c;
        const double dist = diff.norm();
        const double need =
            sphere.margins != nullptr ? sphere.required_m + margins[j] : sphere.required_m;
        const double tj = sphere.t_s + (j + 1) * sphere.dt_s;
        const bool in_window = !sphere.windowed || (sphere.from_s <= tj && tj <= sphere.to_s);
        const bool expect_active = in_window && !(dist - need > sphere.activation_m);
        EXPECT_EQ(bits(distance[j]), bits(dist));
        EXPECT_EQ(active[j], expect_active ? 1 : 0);
        (expect_active ? active_rows : inactive_rows)++;
        if (!(dist > 1e-6)) continue;  // the caller picks another normal there
        const Vec3 normal = diff / dist;
        EXPECT_EQ(bits(nx[j]), bits(normal.x()));
        EXPECT_EQ(bits(ny[j]), bits(normal.y()));
        EXPECT_EQ(bits(nz[j]), bits(normal.z()));
        EXPECT_EQ(bits(bound[j]), bits(normal.dot(c) + need));
      }
    }
  }
  // Both outcomes of the test occurred often (the comparison above saw both).
  EXPECT_GT(active_rows, 100);
  EXPECT_GT(inactive_rows, 100);
}

TEST(SphereRows, MovingCentresEqualTheVec3Expression) {
  const Vec3 centre(812.25, -40.5, 133.0), velocity(-3.7, 1.9, 0.35);
  const double appear_s = 7.3, t_s = 21.02, dt = 0.1;
  for (int n : {1, 3, 4, 7, 40}) {
    std::vector<double> cx(n), cy(n), cz(n);
    moving_centres(centre, velocity, appear_s, t_s, dt, n, cx.data(), cy.data(), cz.data());
    for (int j = 0; j < n; ++j) {
      const double tj = t_s + (j + 1) * dt;
      const Vec3 c = centre + velocity * (tj - appear_s);  // eq. 13, as the tracker wrote it
      EXPECT_EQ(bits(cx[j]), bits(c.x())) << "n " << n << " step " << j;
      EXPECT_EQ(bits(cy[j]), bits(c.y())) << "n " << n << " step " << j;
      EXPECT_EQ(bits(cz[j]), bits(c.z())) << "n " << n << " step " << j;
    }
  }
}

}  // namespace
}  // namespace ridgeline::mpc
