#include "messages/messages.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/simd_clones.hpp"

namespace ridgeline::messages {
namespace {

std::optional<std::string> check_uav(const char* field, int id, int num_uavs) {
  if (id < 0 || id >= num_uavs)
    return fmt::format("{} {} is not a UAV of this team (0..{})", field, id, num_uavs - 1);
  return std::nullopt;
}

// Every coordinate of the points is finite, checked over their contiguous coordinates at once
// (a received trajectory carries up to a few hundred; a point-by-point test with early exits
// cost a twentieth of the agents' share of a flight's instructions).
bool all_finite(const std::vector<Vec3>& points) {
  static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 is three contiguous doubles");
  return points.empty() ||
         entries_finite(points.front().data(), 3 * static_cast<std::ptrdiff_t>(points.size()));
}

std::optional<std::string> check_stamp(double stamp_s) {
  if (!std::isfinite(stamp_s) || stamp_s < 0.0)
    return fmt::format("stamp {} s is invalid", stamp_s);
  return std::nullopt;
}

struct Checker {
  int num_uavs;
  std::size_t max_points;

  std::optional<std::string> operator()(const PredictedTrajectory& m) const {
    if (auto e = check_uav("uav", m.uav, num_uavs)) return e;
    if (auto e = check_stamp(m.stamp_s)) return e;
    if (!(std::isfinite(m.step_s) && m.step_s > 0.0))
      return fmt::format("step {} s is invalid", m.step_s);
    if (m.positions_m.empty() || m.positions_m.size() > max_points)
      return fmt::format("{} positions, expected 1..{}", m.positions_m.size(), max_points);
    if (!all_finite(m.positions_m)) return std::string("a position is not finite");
    if (m.intent_m.size() > max_points)
      return fmt::format("{} intent samples, expected at most {}", m.intent_m.size(), max_points);
    if (!(std::isfinite(m.intent_start_s) && std::isfinite(m.intent_step_s) && m.intent_step_s > 0.0))
      return fmt::format("intent start {} s or step {} s is invalid", m.intent_start_s,
                         m.intent_step_s);
    if (!all_finite(m.intent_m)) return std::string("an intent sample is not finite");
    return std::nullopt;
  }
  std::optional<std::string> operator()(const ThreatReport& m) const {
    if (auto e = check_uav("reporter", m.reporter, num_uavs)) return e;
    if (auto e = check_stamp(m.stamp_s)) return e;
    if (m.threat_id < 0) return fmt::format("threat id {} is negative", m.threat_id);
    if (!m.centre_m.allFinite() || !m.velocity_m_s.allFinite())
      return std::string("centre or velocity is not finite");
    if (!(std::isfinite(m.radius_m) && m.radius_m > 0.0))
      return fmt::format("radius {} m is invalid", m.radius_m);
    return std::nullopt;
  }
  std::optional<std::string> operator()(const StateReport& m) const {
    if (auto e = check_uav("uav", m.uav, num_uavs)) return e;
    if (auto e = check_stamp(m.stamp_s)) return e;
    if (!m.state.allFinite()) return std::string("state is not finite");
    return std::nullopt;
  }
  std::optional<std::string> operator()(const ReferencePlan& m) const {
    return check_plan(m, num_uavs, std::numeric_limits<int>::max());
  }
};

struct TypeName {
  const char* operator()(const PredictedTrajectory&) const { return "PredictedTrajectory"; }
  const char* operator()(const ThreatReport&) const { return "ThreatReport"; }
  const char* operator()(const StateReport&) const { return "StateReport"; }
  const char* operator()(const ReferencePlan&) const { return "ReferencePlan"; }
};

}  // namespace

std::optional<std::string> check_plan(const ReferencePlan& p, int num_uavs, int num_targets,
                                      std::size_t max_samples) {
  if (auto e = check_uav("uav", p.uav, num_uavs)) return e;
  if (p.version < 0) return fmt::format("version {} is negative", p.version);
  if (auto e = check_stamp(p.stamp_s)) return e;
  if (p.times_s.size() < 2 || p.times_s.size() > max_samples || p.points.size() != p.times_s.size())
    return fmt::format("{} times and {} points: need 2..{} of each, equally many", p.times_s.size(),
                       p.points.size(), max_samples);
  for (std::size_t k = 0; k < p.times_s.size(); ++k) {
    const ReferencePoint& q = p.points[k];
    if (!(std::isfinite(p.times_s[k]) && q.position_m.allFinite() && std::isfinite(q.heading_rad) &&
          std::isfinite(q.speed_m_s) && std::isfinite(q.turn_rate_rad_s) &&
          std::isfinite(q.climb_rate_m_s)))
      return fmt::format("sample {} is not finite", k);
    if (k > 0 && !(p.times_s[k] > p.times_s[k - 1]))
      return fmt::format("times are not increasing at sample {}", k);
  }
  for (const int id : p.target_ids)
    if (id < 0 || id >= num_targets)
      return fmt::format("target {} is not a target of the scenario (0..{})", id, num_targets - 1);
  return std::nullopt;
}

std::optional<std::string> check_message(const Message& message, int num_uavs,
                                         std::size_t max_points) {
  return std::visit(Checker{num_uavs, max_points}, message);
}

const char* message_type_name(const Message& message) { return std::visit(TypeName{}, message); }

Vec3 expected_position(const PredictedTrajectory& prediction, double t_s) {
  const std::vector<Vec3>& p = prediction.positions_m;
  const int n = static_cast<int>(p.size());
  const double prediction_end_s = prediction.stamp_s + prediction.step_s * n;
  if (n == 0) return Vec3::Zero();
  if (t_s <= prediction_end_s) return predicted_position(prediction, t_s);
  const std::vector<Vec3>& q = prediction.intent_m;
  const int m = static_cast<int>(q.size());
  if (m >= 2) {
    const double f = (t_s - prediction.intent_start_s) / prediction.intent_step_s;
    const int i = segment_index(f, m - 2);
    return q[i] + (f - i) * (q[i + 1] - q[i]);
  }
  if (n < 2) return p.back();
  // Mean horizontal velocity over the prediction: the last segment alone magnifies a turn's end.
  Vec3 velocity = (p.back() - p.front()) / (prediction.step_s * (n - 1));
  velocity.z() = 0.0;
  return p.back() + velocity * (t_s - prediction_end_s);
}

}  // namespace ridgeline::messages
