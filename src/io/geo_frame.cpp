#include "io/geo_frame.hpp"

#include <fmt/format.h>
#include <proj.h>

#include <cmath>
#include <sstream>
#include <vector>

#include "core/error.hpp"

namespace ridgeline::io {

// One PROJ context per frame: PROJ objects are not safe to share between threads, and a
// private context keeps the error state of one frame from leaking into another.
struct GeoFrame::Impl {
  PJ_CONTEXT* context = nullptr;
  PJ* projection = nullptr;
  ~Impl() {
    if (projection != nullptr) proj_destroy(projection);
    if (context != nullptr) proj_context_destroy(context);
  }
};

GeoFrame::GeoFrame(const mission::GeodeticOrigin& origin)
    : origin_(origin), impl_(std::make_unique<Impl>()) {
  // The transverse Mercator's series are accurate far beyond any mission area, but a frame
  // centred at a pole has no east and north.
  if (!std::isfinite(origin.lat_deg) || std::abs(origin.lat_deg) > 89.0) {
    throw InputError(
        "origin.lat_deg",
        fmt::format("must be a latitude in [-89, 89] degrees, got {}", origin.lat_deg));
  }
  if (!std::isfinite(origin.lon_deg) || std::abs(origin.lon_deg) > 180.0) {
    throw InputError("origin.lon_deg", fmt::format("must be a longitude in [-180, 180] degrees, "
                                                   "got {}",
                                                   origin.lon_deg));
  }
  if (!std::isfinite(origin.alt_amsl_m)) {
    throw InputError("origin.alt_amsl_m", fmt::format("must be finite, got {}", origin.alt_amsl_m));
  }
  definition_ = fmt::format(
      "+proj=tmerc +lat_0={:.12f} +lon_0={:.12f} +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m "
      "+no_defs +type=crs",
      origin.lat_deg, origin.lon_deg);
  impl_->context = proj_context_create();
  if (impl_->context == nullptr) throw InputError("origin", "PROJ cannot create a context");
  proj_log_level(impl_->context, PJ_LOG_NONE);
  // Without "+type=crs" the string is a bare conversion whose forward direction takes
  // geodetic longitude/latitude in radians, which is what to_local feeds it.
  const std::string conversion = fmt::format(
      "+proj=tmerc +lat_0={:.12f} +lon_0={:.12f} +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m",
      origin.lat_deg, origin.lon_deg);
  impl_->projection = proj_create(impl_->context, conversion.c_str());
  if (impl_->projection == nullptr) {
    throw InputError(
        "origin",
        fmt::format("PROJ cannot build the local projection '{}': {}", conversion,
                    proj_context_errno_string(impl_->context, proj_context_errno(impl_->context))));
  }
}

GeoFrame::~GeoFrame() = default;
GeoFrame::GeoFrame(GeoFrame&&) noexcept = default;
GeoFrame& GeoFrame::operator=(GeoFrame&&) noexcept = default;

Vec3 GeoFrame::to_local(const GeoPoint& p, const std::string& what) const {
  if (!std::isfinite(p.lat_deg) || std::abs(p.lat_deg) > 90.0) {
    throw InputError(what, fmt::format("latitude {} is not in [-90, 90] degrees", p.lat_deg));
  }
  if (!std::isfinite(p.lon_deg) || std::abs(p.lon_deg) > 180.0) {
    throw InputError(what, fmt::format("longitude {} is not in [-180, 180] degrees", p.lon_deg));
  }
  if (!std::isfinite(p.alt_amsl_m)) {
    throw InputError(what, fmt::format("altitude {} is not finite", p.alt_amsl_m));
  }
  PJ_COORD in = proj_coord(proj_torad(p.lon_deg), proj_torad(p.lat_deg), 0.0, 0.0);
  proj_errno_reset(impl_->projection);
  const PJ_COORD out = proj_trans(impl_->projection, PJ_FWD, in);
  if (!std::isfinite(out.xy.x) || !std::isfinite(out.xy.y) || out.xy.x == HUGE_VAL ||
      proj_errno(impl_->projection) != 0) {
    throw InputError(what, fmt::format("({}, {}) cannot be projected into the local frame "
                                       "centred on ({}, {})",
                                       p.lat_deg, p.lon_deg, origin_.lat_deg, origin_.lon_deg));
  }
  return Vec3(out.xy.x, out.xy.y, p.alt_amsl_m);
}

GeoPoint GeoFrame::to_geodetic(const Vec3& local_m) const {
  PJ_COORD in = proj_coord(local_m.x(), local_m.y(), 0.0, 0.0);
  const PJ_COORD out = proj_trans(impl_->projection, PJ_INV, in);
  return {proj_todeg(out.lp.phi), proj_todeg(out.lp.lam), local_m.z()};
}

mission::GeodeticOrigin parse_origin_text(const std::string& text, const std::string& field) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw InputError(field, "'" + item + "' is not a number (expected LAT,LON,ALT_AMSL)");
    }
  }
  if (v.size() != 3) {
    throw InputError(field,
                     "expected LAT,LON,ALT_AMSL (degrees, degrees, metres), got '" + text + "'");
  }
  return {v[0], v[1], v[2]};
}

}  // namespace ridgeline::io
