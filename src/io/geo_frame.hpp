// The geographic frame of a scenario (DESIGN §8): a geodetic origin and the local metric ENU
// frame around it.
//
// The local frame is a transverse Mercator projection of the WGS 84 ellipsoid centred on the
// origin (PROJ `+proj=tmerc +lat_0=φ0 +lon_0=λ0 +k=1 +x_0=0 +y_0=0 +datum=WGS84`):
//   x = easting from the origin (m), y = northing from the origin (m),
//   z = height above mean sea level (m), the vertical datum of the DEM (SRTM: EGM96 geoid).
// So (0, 0) is the origin's horizontal position and z is NOT shifted by the origin's altitude:
// terrain heights are the DEM's real elevations and a position's z is its altitude AMSL.
// Within 10 km of the origin the projection's scale error is below 1.3e-6 (k = 1 at the
// central meridian, growing as 1 + x²/2R²), i.e. under 1.3 mm per km; grid north differs from
// true north by the meridian convergence (about Δλ·sin φ), which the projection accounts for.
// No vertical datum conversion is done: heights are taken as the DEM gives them.
#pragma once

#include <memory>
#include <string>

#include "core/types.hpp"
#include "mission/scenario.hpp"

namespace ridgeline::io {

/// A WGS 84 position: latitude and longitude in degrees, altitude above mean sea level.
struct GeoPoint {
  double lat_deg = 0.0;
  double lon_deg = 0.0;
  double alt_amsl_m = 0.0;
};

/// Converts between WGS 84 latitude/longitude and the local frame above (PROJ). Not thread
/// safe: use one object per thread.
class GeoFrame {
 public:
  /// Throws InputError (field `origin`) unless the latitude is in [-89, 89] degrees, the
  /// longitude in [-180, 180] and the altitude finite, or when PROJ cannot build the
  /// projection.
  explicit GeoFrame(const mission::GeodeticOrigin& origin);
  ~GeoFrame();
  GeoFrame(GeoFrame&&) noexcept;
  GeoFrame& operator=(GeoFrame&&) noexcept;
  GeoFrame(const GeoFrame&) = delete;
  GeoFrame& operator=(const GeoFrame&) = delete;

  /// Local ENU (m) of a geodetic point; z = its altitude AMSL. Throws InputError (field
  /// `what`) on a non-finite or out-of-range latitude/longitude.
  Vec3 to_local(const GeoPoint& point, const std::string& what = "position") const;
  /// The geodetic point of a local position; altitude = z.
  GeoPoint to_geodetic(const Vec3& local_m) const;

  const mission::GeodeticOrigin& origin() const { return origin_; }
  /// The PROJ string of the local projection (usable as a GDAL/OGR CRS definition).
  const std::string& proj_definition() const { return definition_; }

 private:
  struct Impl;
  mission::GeodeticOrigin origin_;
  std::string definition_;
  std::unique_ptr<Impl> impl_;
};

/// "LAT,LON,ALT_AMSL" (degrees, degrees, metres), as command-line options give an origin.
/// Throws InputError naming `field` unless it is three numbers; GeoFrame checks their ranges.
mission::GeodeticOrigin parse_origin_text(const std::string& text, const std::string& field);

}  // namespace ridgeline::io
