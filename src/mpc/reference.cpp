#include "mpc/reference.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.hpp"
#include "core/sin_cos.hpp"

namespace ridgeline::mpc {

namespace {

bool finite(const ReferencePoint& p) {
  return p.position_m.allFinite() && std::isfinite(p.heading_rad) && std::isfinite(p.speed_m_s) &&
         std::isfinite(p.turn_rate_rad_s) && std::isfinite(p.climb_rate_m_s);
}

void check_times(const std::vector<double>& times_s, std::size_t count) {
  if (times_s.size() != count) {
    throw InputError("points", "has " + std::to_string(count) + " samples but times_s has " +
                                   std::to_string(times_s.size()));
  }
  if (times_s.size() < 2) throw InputError("times_s", "needs at least 2 samples");
  for (std::size_t i = 0; i < times_s.size(); ++i) {
    if (!std::isfinite(times_s[i])) {
      throw InputError("times_s[" + std::to_string(i) + "]", "is not finite");
    }
    if (i > 0 && !(times_s[i] > times_s[i - 1])) {
      throw InputError("times_s[" + std::to_string(i) + "]", "times must increase strictly");
    }
  }
}

// Moves a point along its own velocity for dt seconds (heading, speed, rates held except the
// heading, which turns at the turn rate).
ReferencePoint extrapolate(const ReferencePoint& p, double dt_s) {
  ReferencePoint q = p;
  const double omega = p.turn_rate_rad_s;
  if (std::abs(omega) * std::abs(dt_s) < 1e-9) {
    q.position_m.x() += p.speed_m_s * std::cos(p.heading_rad) * dt_s;
    q.position_m.y() += p.speed_m_s * std::sin(p.heading_rad) * dt_s;
  } else {
    // Exact arc at constant turn rate.
    const double psi1 = p.heading_rad + omega * dt_s;
    q.position_m.x() += p.speed_m_s / omega * (std::sin(psi1) - std::sin(p.heading_rad));
    q.position_m.y() += p.speed_m_s / omega * (std::cos(p.heading_rad) - std::cos(psi1));
    q.heading_rad = psi1;
  }
  q.position_m.z() += p.climb_rate_m_s * dt_s;
  return q;
}

}  // namespace

SampledReference::SampledReference(std::vector<double> times_s, std::vector<ReferencePoint> points)
    : times_s_(std::move(times_s)), points_(std::move(points)) {
  check_times(times_s_, points_.size());
  for (std::size_t i = 0; i < points_.size(); ++i) {
    if (!finite(points_[i])) {
      throw InputError("points[" + std::to_string(i) + "]", "has a non-finite value");
    }
  }
}

SampledReference SampledReference::from_positions(const std::vector<double>& times_s,
                                                  const std::vector<Vec3>& positions_m) {
  check_times(times_s, positions_m.size());
  const std::size_t n = positions_m.size();
  std::vector<ReferencePoint> pts(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!positions_m[i].allFinite()) {
      throw InputError("positions_m[" + std::to_string(i) + "]", "is not finite");
    }
    if (i + 1 < n && (positions_m[i + 1] - positions_m[i]).head<2>().norm() < 1e-9) {
      throw InputError("positions_m[" + std::to_string(i + 1) + "]",
                       "coincides horizontally with the previous position: heading undefined");
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1;
    const std::size_t b = i + 1 == n ? n - 1 : i + 1;
    const Vec3 vel = (positions_m[b] - positions_m[a]) / (times_s[b] - times_s[a]);
    pts[i].position_m = positions_m[i];
    pts[i].speed_m_s = vel.head<2>().norm();
    pts[i].heading_rad = std::atan2(vel.y(), vel.x());
    pts[i].climb_rate_m_s = vel.z();
  }
  // Unwrap headings into a continuous sequence, then differentiate them.
  for (std::size_t i = 1; i < n; ++i) {
    pts[i].heading_rad =
        pts[i - 1].heading_rad + wrap_angle(pts[i].heading_rad - pts[i - 1].heading_rad);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1;
    const std::size_t b = i + 1 == n ? n - 1 : i + 1;
    pts[i].turn_rate_rad_s = (pts[b].heading_rad - pts[a].heading_rad) / (times_s[b] - times_s[a]);
  }
  return SampledReference(times_s, std::move(pts));
}

void ReferenceTrajectory::sample(double t0_s, double step_s, std::span<ReferencePoint> out) const {
  for (std::size_t j = 0; j < out.size(); ++j) out[j] = at(t0_s + static_cast<double>(j) * step_s);
}

std::size_t SampledReference::segment(double t_s) const {
  // Plans are sampled at about even steps, so the guess from the mean spacing is right or a
  // step off; a few steps of walking confirm it, and a binary search takes over when they do
  // not (the search's unpredictable branches showed in the tracker's step).
  const std::size_t last = times_s_.size() - 1;
  const double where = (t_s - times_s_.front()) / (times_s_.back() - times_s_.front());
  std::size_t i = std::min(static_cast<std::size_t>(where * static_cast<double>(last)), last - 1);
  for (int walk = 0; walk < 4 && times_s_[i] > t_s; ++walk) --i;  // times[0] < t: stays ≥ 0
  for (int walk = 0; walk < 4 && times_s_[i + 1] <= t_s; ++walk) ++i;  // times[last] > t
  if (times_s_[i] > t_s || times_s_[i + 1] <= t_s) {
    const auto it = std::upper_bound(times_s_.begin(), times_s_.end(), t_s);
    i = static_cast<std::size_t>(it - times_s_.begin()) - 1;
  }
  return i;
}

ReferencePoint SampledReference::interpolate(std::size_t i, double t_s) const {
  const double a = (t_s - times_s_[i]) / (times_s_[i + 1] - times_s_[i]);
  const ReferencePoint& p = points_[i];
  const ReferencePoint& q = points_[i + 1];
  ReferencePoint r;
  r.position_m = (1.0 - a) * p.position_m + a * q.position_m;
  r.heading_rad = p.heading_rad + a * wrap_angle(q.heading_rad - p.heading_rad);
  r.speed_m_s = (1.0 - a) * p.speed_m_s + a * q.speed_m_s;
  r.turn_rate_rad_s = (1.0 - a) * p.turn_rate_rad_s + a * q.turn_rate_rad_s;
  r.climb_rate_m_s = (1.0 - a) * p.climb_rate_m_s + a * q.climb_rate_m_s;
  return r;
}

ReferencePoint SampledReference::at(double t_s) const {
  if (t_s <= times_s_.front()) return extrapolate(points_.front(), t_s - times_s_.front());
  if (t_s >= times_s_.back()) return extrapolate(points_.back(), t_s - times_s_.back());
  return interpolate(segment(t_s), t_s);  // front < t < back
}

void SampledReference::at_increasing(std::span<const double> times_s,
                                     std::span<ReferencePoint> out) const {
  const std::size_t n = std::min(times_s.size(), out.size());
  std::size_t i = 0;
  bool walking = false;  // i is the segment of an earlier time, at or before this one's
  for (std::size_t j = 0; j < n; ++j) {
    const double t = times_s[j];
    if (t <= times_s_.front()) {
      out[j] = extrapolate(points_.front(), t - times_s_.front());
    } else if (t >= times_s_.back()) {
      out[j] = extrapolate(points_.back(), t - times_s_.back());
    } else {
      if (walking && times_s_[i] <= t) {
        while (times_s_[i + 1] <= t) ++i;  // stops before the last sample: t < back
      } else {
        i = segment(t);
        walking = true;
      }
      out[j] = interpolate(i, t);
    }
  }
}

void SampledReference::sample(double t0_s, double step_s, std::span<ReferencePoint> out) const {
  constexpr std::size_t kBatch = 16;  // times a call of at_increasing (on the stack)
  double times[kBatch];
  for (std::size_t begin = 0; begin < out.size(); begin += kBatch) {
    const std::size_t count = std::min(kBatch, out.size() - begin);
    for (std::size_t k = 0; k < count; ++k)
      times[k] = t0_s + static_cast<double>(begin + k) * step_s;
    at_increasing(std::span<const double>(times, count), out.subspan(begin, count));
  }
}

HelixReference::HelixReference(const Config& config) : c_(config) {
  if (!(std::isfinite(c_.radius_m) && c_.radius_m > 0.0)) {
    throw InputError("radius_m", "must be finite and > 0");
  }
  if (!(std::isfinite(c_.speed_m_s) && c_.speed_m_s > 0.0)) {
    throw InputError("speed_m_s", "must be finite and > 0");
  }
  if (!c_.centre_m.allFinite() || !std::isfinite(c_.climb_rate_m_s) ||
      !std::isfinite(c_.phase0_rad) || !std::isfinite(c_.t0_s)) {
    throw InputError("centre_m/climb_rate_m_s/phase0_rad/t0_s", "must be finite");
  }
}

double HelixReference::omega_rad_s() const {
  const double sign = c_.turn_left ? 1.0 : -1.0;
  return sign * c_.speed_m_s / c_.radius_m;
}

ReferencePoint HelixReference::point(double dt_s, double phi_rad, double cos_phi,
                                     double sin_phi) const {
  const double sign = c_.turn_left ? 1.0 : -1.0;
  ReferencePoint r;
  r.position_m = c_.centre_m + Vec3(c_.radius_m * cos_phi, c_.radius_m * sin_phi,
                                    c_.climb_rate_m_s * dt_s);
  r.heading_rad = phi_rad + sign * 0.5 * kPi;
  r.speed_m_s = c_.speed_m_s;
  r.turn_rate_rad_s = omega_rad_s();
  r.climb_rate_m_s = c_.climb_rate_m_s;
  return r;
}

ReferencePoint HelixReference::at(double t_s) const {
  const double dt = t_s - c_.t0_s;
  const double phi = c_.phase0_rad + omega_rad_s() * dt;
  return point(dt, phi, std::cos(phi), std::sin(phi));
}

void HelixReference::sample(double t0_s, double step_s, std::span<ReferencePoint> out) const {
  constexpr std::size_t kBatch = 16;  // angles a call of sin_cos (on the stack)
  double dt[kBatch], phi[kBatch], sin_phi[kBatch], cos_phi[kBatch];
  const double omega = omega_rad_s();
  for (std::size_t begin = 0; begin < out.size(); begin += kBatch) {
    const std::size_t count = std::min(kBatch, out.size() - begin);
    for (std::size_t k = 0; k < count; ++k) {
      dt[k] = (t0_s + static_cast<double>(begin + k) * step_s) - c_.t0_s;
      phi[k] = c_.phase0_rad + omega * dt[k];
    }
    sin_cos(phi, sin_phi, cos_phi, static_cast<int>(count));
    for (std::size_t k = 0; k < count; ++k)
      out[begin + k] = point(dt[k], phi[k], cos_phi[k], sin_phi[k]);
  }
}

}  // namespace ridgeline::mpc
