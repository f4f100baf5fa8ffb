// The local transverse Mercator frame against references that share no code with it: the
// ellipsoid's radii of curvature for small offsets and Karney's geodesics (PROJ's geodesic.h,
// a separate algorithm from the projection) for distances.
#include "io/geo_frame.hpp"

#include <geodesic.h>
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.hpp"
#include "core/random.hpp"

namespace ridgeline::io {
namespace {

constexpr double kA = 6378137.0;            // WGS 84 semi-major axis, m
constexpr double kF = 1.0 / 298.257223563;  // WGS 84 flattening
constexpr double kE2 = kF * (2.0 - kF);     // first eccentricity squared

// Metres per degree of latitude (meridian radius M) and of longitude (N cos φ) at φ.
double metres_per_deg_lat(double lat_deg) {
  const double s = std::sin(deg_to_rad(lat_deg));
  return deg_to_rad(1.0) * kA * (1.0 - kE2) / std::pow(1.0 - kE2 * s * s, 1.5);
}
double metres_per_deg_lon(double lat_deg) {
  const double s = std::sin(deg_to_rad(lat_deg));
  return deg_to_rad(1.0) * kA * std::cos(deg_to_rad(lat_deg)) / std::sqrt(1.0 - kE2 * s * s);
}

TEST(GeoFrame, LatLonToLocalAndBackWithinOneMillimetre) {
  Rng rng(20261123);
  for (int o = 0; o < 40; ++o) {
    const mission::GeodeticOrigin origin{rng.uniform(-80.0, 80.0), rng.uniform(-179.0, 179.0),
                                         rng.uniform(-100.0, 4000.0)};
    const GeoFrame frame(origin);
    for (int k = 0; k < 250; ++k) {
      // Up to ~30 km from the origin: far beyond a mission area.
      const GeoPoint p{origin.lat_deg + rng.uniform(-0.25, 0.25),
                       origin.lon_deg + rng.uniform(-0.25, 0.25), rng.uniform(0.0, 5000.0)};
      const Vec3 local = frame.to_local(p);
      const GeoPoint back = frame.to_geodetic(local);
      const double north_err_m = (back.lat_deg - p.lat_deg) * metres_per_deg_lat(p.lat_deg);
      const double east_err_m = (back.lon_deg - p.lon_deg) * metres_per_deg_lon(p.lat_deg);
      ASSERT_LT(std::hypot(north_err_m, east_err_m), 1e-3) << origin.lat_deg << " " << k;
      ASSERT_EQ(back.alt_amsl_m, p.alt_amsl_m);
      ASSERT_EQ(local.z(), p.alt_amsl_m);  // z is the altitude AMSL, not shifted
      // And the other way: local -> lat/lon -> local.
      const Vec3 q(rng.uniform(-20e3, 20e3), rng.uniform(-20e3, 20e3), 123.0);
      ASSERT_LT((frame.to_local(frame.to_geodetic(q)) - q).norm(), 1e-3);
    }
  }
}

TEST(GeoFrame, OriginIsZeroAndSmallOffsetsFollowTheRadiiOfCurvature) {
  Rng rng(7);
  for (int o = 0; o < 50; ++o) {
    const mission::GeodeticOrigin origin{rng.uniform(-70.0, 70.0), rng.uniform(-180.0, 180.0),
                                         500.0};
    const GeoFrame frame(origin);
    const Vec3 zero = frame.to_local({origin.lat_deg, origin.lon_deg, 0.0});
    EXPECT_LT(std::hypot(zero.x(), zero.y()), 1e-6);
    // Within 30 m the neglected second-order terms are below d²·tan φ / R < 0.4 mm at 70°.
    const double dn_m = rng.uniform(-30.0, 30.0), de_m = rng.uniform(-30.0, 30.0);
    const Vec3 p =
        frame.to_local({origin.lat_deg + dn_m / metres_per_deg_lat(origin.lat_deg),
                        origin.lon_deg + de_m / metres_per_deg_lon(origin.lat_deg), 0.0});
    EXPECT_NEAR(p.x(), de_m, 1e-3) << origin.lat_deg;
    EXPECT_NEAR(p.y(), dn_m, 1e-3) << origin.lat_deg;
  }
}

TEST(GeoFrame, GridDistancesMatchGeodesicsNearTheOrigin) {
  geod_geodesic g;
  geod_init(&g, kA, kF);
  Rng rng(99);
  for (int o = 0; o < 20; ++o) {
    const mission::GeodeticOrigin origin{rng.uniform(-60.0, 60.0), rng.uniform(-180.0, 180.0), 0.0};
    const GeoFrame frame(origin);
    for (int k = 0; k < 50; ++k) {
      const Vec3 a(rng.uniform(-5e3, 5e3), rng.uniform(-5e3, 5e3), 0.0);
      const Vec3 b(rng.uniform(-5e3, 5e3), rng.uniform(-5e3, 5e3), 0.0);
      const GeoPoint ga = frame.to_geodetic(a), gb = frame.to_geodetic(b);
      double s12 = 0.0, azi1 = 0.0, azi2 = 0.0;
      geod_inverse(&g, ga.lat_deg, ga.lon_deg, gb.lat_deg, gb.lon_deg, &s12, &azi1, &azi2);
      // Transverse Mercator scale k = 1 + x²/2R² + ...: within 5 km of the central meridian
      // grid and true distances differ by less than 3.1e-7 relative (0.3 mm per km).
      EXPECT_NEAR((a - b).norm(), s12, 3.1e-7 * s12 + 1e-6);
    }
  }
}

TEST(GeoFrame, BadOriginsAndPointsAreErrorsNamingTheField) {
  try {
    GeoFrame frame({91.0, 0.0, 0.0});
    FAIL() << "a latitude of 91 degrees was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "origin.lat_deg");
  }
  EXPECT_THROW(GeoFrame({10.0, 200.0, 0.0}), InputError);
  EXPECT_THROW(GeoFrame({10.0, 20.0, std::nan("")}), InputError);
  const GeoFrame frame({46.5, 8.0, 800.0});
  try {
    (void)frame.to_local({std::nan(""), 8.0, 900.0}, "targets[0].position_geo");
    FAIL() << "a NaN latitude was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "targets[0].position_geo");
  }
}

}  // namespace
}  // namespace ridgeline::io
