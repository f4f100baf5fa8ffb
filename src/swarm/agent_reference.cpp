#include "swarm/agent_reference.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <fmt/format.h>

namespace ridgeline::swarm {

AgentReference::AgentReference(std::shared_ptr<const mpc::SampledReference> plan)
    : plan_(std::move(plan)) {}

mpc::ReferencePoint AgentReference::plan_at(double t_s) const { return plan_->at(t_s - delay_s_); }

mpc::ReferencePoint AgentReference::at(double t_s) const {
  if (detour_ && t_s >= detour_->start_time_s() && t_s <= detour_->end_time_s())
    return detour_->at(t_s);
  return plan_at(t_s);
}

double AgentReference::rejoin(double t_s, const Vec3& position_m, double max_back_s,
                              double max_ahead_s) {
  const double now_plan = t_s - delay_s_;
  const double lo = std::max(plan_->start_time_s(), now_plan - max_back_s);
  const double hi = std::min(plan_->end_time_s(), now_plan + max_ahead_s);
  double best_time = std::clamp(now_plan, plan_->start_time_s(), plan_->end_time_s());
  double best = std::numeric_limits<double>::infinity();
  // 0.1 s is 1 m at cruise: finer than the tracker's own error.
  for (double tp = lo; tp <= hi; tp += 0.1) {
    const double d = (plan_->at(tp).position_m - position_m).norm();
    if (d < best) {
      best = d;
      best_time = tp;
    }
  }
  delay_s_ = t_s - best_time;
  detour_.reset();
  return delay_s_;
}

void AgentReference::set_detour(std::optional<mpc::SampledReference> detour) {
  detour_ = std::move(detour);
}

namespace {

Vec2 horizontal(const Vec3& v) { return Vec2(v.x(), v.y()); }

}  // namespace

DetourResult plan_detour(const mpc::ReferenceTrajectory& reference, double t_s,
                         std::span<const world::Threat> threats, const world::Terrain& terrain,
                         const DetourOptions& o) {
  DetourResult result;
  const int n = std::max(2, static_cast<int>(std::ceil(o.lookahead_s / o.sample_step_s)) + 1);
  std::vector<double> times(n);
  std::vector<mpc::ReferencePoint> base(n);
  for (int j = 0; j < n; ++j) {
    times[j] = t_s + j * o.sample_step_s;
    base[j] = reference.at(times[j]);
  }
  // Required push per sample: the largest over the threats of the missing horizontal distance,
  // with its direction (away from that threat's centre at the sample's own time).
  std::vector<Vec2> push(n, Vec2::Zero());
  bool conflict = false;
  for (const world::Threat& threat : threats) {
    const double keep = threat.radius_m + o.threat_margin_m + o.clearance_m;
    std::vector<double> need(n, 0.0);
    std::vector<Vec2> away(n, Vec2::Zero());
    bool any = false;
    for (int j = 0; j < n; ++j) {
      if (!threat.active(times[j])) continue;
      const Vec2 d = horizontal(base[j].position_m - threat.centre_at(times[j]));
      const double dist = d.norm();
      if (dist >= keep) continue;
      any = true;
      need[j] = keep - dist;
      // On the centre line the side is arbitrary; take the reference's left.
      away[j] = dist > 1e-6 ? Vec2(d / dist)
                            : Vec2(-std::sin(base[j].heading_rad), std::cos(base[j].heading_rad));
    }
    if (!any) continue;
    conflict = true;
    // One side for the whole encounter: the side of the deepest sample. Flipping sides in the
    // middle would cut through the threat.
    const int deepest = static_cast<int>(std::max_element(need.begin(), need.end()) - need.begin());
    const Vec2 side = away[deepest];
    // Dilate in time: the offset may change by at most lateral_rate·|Δt|.
    std::vector<double> offset(n, 0.0);
    for (int j = 0; j < n; ++j) {
      for (int k = 0; k < n; ++k) {
        if (need[k] <= 0.0) continue;
        offset[j] = std::max(offset[j], need[k] - o.lateral_rate_m_s * std::abs(times[j] - times[k]));
      }
    }
    for (int j = 0; j < n; ++j) {
      if (offset[j] <= 0.0) continue;
      // Where the sample is beside the threat, push away from its centre; elsewhere along the
      // encounter's side, so the ramps in and out do not swing around the centre.
      Vec2 dir = need[j] > 0.0 ? away[j] : side;
      if (dir.dot(side) < 0.0) dir = side;
      push[j] += offset[j] * dir;
    }
  }
  if (!conflict) return result;

  std::vector<Vec3> positions(n);
  for (int j = 0; j < n; ++j) {
    positions[j] = base[j].position_m;
    positions[j].head<2>() += push[j];
    const double floor =
        std::max(o.min_altitude_m, terrain.height(positions[j].x(), positions[j].y()) +
                                       o.terrain_clearance_m + terrain.model_error_m() + 5.0);
    positions[j].z() = std::max(positions[j].z(), floor);
  }
  // Climb limit: a sample may be at most w·Δt above its neighbours; raise earlier samples
  // (backward pass) so the climb starts in time, then the later ones (forward pass).
  const double rise = 0.8 * o.max_climb_rate_m_s * o.sample_step_s;
  for (int j = n - 2; j >= 0; --j)
    positions[j].z() = std::max(positions[j].z(), positions[j + 1].z() - rise);
  for (int j = 1; j < n; ++j)
    positions[j].z() = std::max(positions[j].z(), positions[j - 1].z() - rise);
  for (int j = 0; j < n; ++j) {
    if (positions[j].z() > o.max_altitude_m) {
      result.status = DetourResult::Status::kFailed;
      result.message = fmt::format(
          "detour: at t = {:.1f} s it would need z = {:.1f} m, above the altitude limit {:.1f} m",
          times[j], positions[j].z(), o.max_altitude_m);
      return result;
    }
  }
  try {
    result.reference = mpc::SampledReference::from_positions(times, positions);
  } catch (const std::exception& e) {
    result.status = DetourResult::Status::kFailed;
    result.message = fmt::format("detour: {}", e.what());
    return result;
  }
  result.status = DetourResult::Status::kPlanned;
  return result;
}

}  // namespace ridgeline::swarm
