#include "world/threat.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace ridgeline::world {
namespace {

std::string field_path(std::string_view prefix, std::string_view field) {
  if (prefix.empty()) return std::string(field);
  return fmt::format("{}.{}", prefix, field);
}

void require_finite(const Vec3& v, std::string_view prefix, std::string_view field) {
  if (!v.allFinite()) {
    throw InputError(field_path(prefix, field),
                     fmt::format("must be finite, got [{}, {}, {}]", v.x(), v.y(), v.z()));
  }
}

void require_finite(double value, std::string_view prefix, std::string_view field) {
  if (!std::isfinite(value)) {
    throw InputError(field_path(prefix, field), fmt::format("must be finite, got {}", value));
  }
}

}  // namespace

double Threat::surface_distance(const Vec3& p_m, double t_s) const {
  if (!active(t_s)) return std::numeric_limits<double>::infinity();
  return (p_m - centre_at(t_s)).norm() - radius_m;
}

bool Threat::sensed_by(const Vec3& sensor_p_m, double sensor_range_m, double t_s) const {
  // An inactive threat has distance +inf, which no finite range reaches.
  return surface_distance(sensor_p_m, t_s) <= sensor_range_m;
}

void validate(const Threat& threat, std::string_view field_prefix) {
  require_finite(threat.centre_m, field_prefix, "centre_m");
  require_finite(threat.velocity_m_s, field_prefix, "velocity_m_s");
  require_finite(threat.radius_m, field_prefix, "radius_m");
  if (threat.radius_m <= 0.0) {
    throw InputError(field_path(field_prefix, "radius_m"),
                     fmt::format("must be > 0, got {}", threat.radius_m));
  }
  require_finite(threat.appear_s, field_prefix, "appear_s");
  require_finite(threat.vanish_s, field_prefix, "vanish_s");
  if (threat.vanish_s <= threat.appear_s) {
    throw InputError(
        field_path(field_prefix, "vanish_s"),
        fmt::format("must be later than appear_s ({}), got {}", threat.appear_s, threat.vanish_s));
  }
}

std::optional<ClosestApproach> closest_approach(const Threat& threat, const Vec3& point_ref_m,
                                                const Vec3& point_velocity_m_s, double t_ref_s,
                                                double t_begin_s, double t_end_s) {
  const double lo = std::max(t_begin_s, threat.appear_s);
  const double hi = std::min(t_end_s, threat.vanish_s);
  if (!(lo <= hi)) return std::nullopt;

  const Vec3 d_ref = point_ref_m - threat.centre_at(t_ref_s);
  const Vec3 dv = point_velocity_m_s - threat.velocity_m_s;
  const double dv2 = dv.squaredNorm();
  double t_star = lo;
  if (dv2 > 0.0) t_star = std::clamp(t_ref_s - d_ref.dot(dv) / dv2, lo, hi);

  ClosestApproach ca;
  ca.time_s = t_star;
  ca.point_m = point_ref_m + point_velocity_m_s * (t_star - t_ref_s);
  ca.threat_centre_m = threat.centre_at(t_star);
  ca.centre_distance_m = (ca.point_m - ca.threat_centre_m).norm();
  ca.surface_distance_m = ca.centre_distance_m - threat.radius_m;
  return ca;
}

}  // namespace ridgeline::world
