#include "swarm/agent_reference.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <fmt/format.h>

namespace ridgeline::swarm {

AgentReference::AgentReference(std::shared_ptr<const mpc::SampledReference> plan)
    : plan_(std::move(plan)) {}

double AgentReference::delay_at(double t_s) const {
  if (delay_target_s_ == delay_from_s_ || t_s <= delay_since_s_) return delay_from_s_;
  return std::min(delay_target_s_, delay_from_s_ + delay_rate_ * (t_s - delay_since_s_));
}

void AgentReference::slow_down(double t_s, double delay_s, mpc::ReferencePoint& p) const {
  if (delay_s < delay_target_s_ && t_s >= delay_since_s_) {
    // d/dt r_plan(t − δ(t)) = (1 − δ̇)·ṙ_plan: the same path, flown slower.
    const double along = 1.0 - delay_rate_;
    p.speed_m_s *= along;
    p.turn_rate_rad_s *= along;
    p.climb_rate_m_s *= along;
  }
}

void AgentReference::raise_to_level(double t_s, mpc::ReferencePoint& p) const {
  if (level_target_m_ != 0.0 || level_from_m_ != 0.0) {
    const double level = level_at(t_s);
    p.position_m.z() += level;
    if (level != level_target_m_ && t_s >= level_since_s_)
      p.climb_rate_m_s += level_target_m_ > level ? level_rate_m_s_ : -level_rate_m_s_;
  }
}

mpc::ReferencePoint AgentReference::plan_at(double t_s) const {
  const double delay = delay_at(t_s);
  mpc::ReferencePoint p = plan_->at(t_s - delay);
  slow_down(t_s, delay, p);
  return p;
}

void AgentReference::set_delay(double t_s, double target_s, double rate) {
  const double now = delay_at(t_s);
  delay_from_s_ = now;
  delay_since_s_ = t_s;
  delay_target_s_ = std::max(now, target_s);
  delay_rate_ = std::clamp(rate, 0.0, 0.95);
  ++revision_;
}

mpc::ReferencePoint AgentReference::at(double t_s) const {
  mpc::ReferencePoint p = detour_ && t_s >= detour_->start_time_s() && t_s <= detour_->end_time_s()
                              ? detour_->at(t_s)
                              : plan_at(t_s);
  raise_to_level(t_s, p);
  return p;
}

void AgentReference::sample(double t0_s, double step_s, std::span<mpc::ReferencePoint> out) const {
  if (out.empty()) return;
  const double last_s = t0_s + static_cast<double>(out.size() - 1) * step_s;
  if (!(step_s >= 0.0) ||
      (detour_ && last_s >= detour_->start_time_s() && t0_s <= detour_->end_time_s())) {
    ReferenceTrajectory::sample(t0_s, step_s, out);  // a detour within the samples' times
    return;
  }
  // The plan alone: its times t − δ(t) increase (δ grows at a rate below 1), so its look-ups
  // walk on from one another (SampledReference::at_increasing), each equal to plan_->at().
  constexpr std::size_t kBatch = 16;  // samples a call (on the stack)
  double time[kBatch], delay[kBatch], plan_time[kBatch];
  for (std::size_t begin = 0; begin < out.size(); begin += kBatch) {
    const std::size_t count = std::min(kBatch, out.size() - begin);
    for (std::size_t k = 0; k < count; ++k) {
      time[k] = t0_s + static_cast<double>(begin + k) * step_s;
      delay[k] = delay_at(time[k]);
      plan_time[k] = time[k] - delay[k];
    }
    const std::span<mpc::ReferencePoint> chunk = out.subspan(begin, count);
    plan_->at_increasing(std::span<const double>(plan_time, count), chunk);
    for (std::size_t k = 0; k < count; ++k) {
      slow_down(time[k], delay[k], chunk[k]);
      raise_to_level(time[k], chunk[k]);
    }
  }
}

void AgentReference::set_level(double t_s, double target_m, double rate_m_s) {
  level_from_m_ = level_at(t_s);
  level_since_s_ = t_s;
  level_target_m_ = target_m;
  level_rate_m_s_ = rate_m_s;
  ++revision_;
}

double AgentReference::level_at(double t_s) const {
  const double moved = level_rate_m_s_ * std::max(0.0, t_s - level_since_s_);
  const double gap = level_target_m_ - level_from_m_;
  return std::abs(gap) <= moved ? level_target_m_ : level_from_m_ + std::copysign(moved, gap);
}

double AgentReference::rejoin(double t_s, const Vec3& position_m, double max_back_s,
                              double max_ahead_s) {
  const double now_plan = t_s - delay_at(t_s);
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
  rewind(t_s, best_time);
  return delay_target_s_;
}

void AgentReference::rewind(double t_s, double plan_time_s) {
  delay_from_s_ = delay_target_s_ =
      t_s - std::clamp(plan_time_s, plan_->start_time_s(), plan_->end_time_s());
  delay_since_s_ = t_s;
  detour_.reset();
  ++revision_;
}

void AgentReference::set_detour(std::optional<mpc::SampledReference> detour) {
  if (!detour && !detour_) return;
  detour_ = std::move(detour);
  ++revision_;
}

namespace {

Vec2 horizontal(const Vec3& v) { return Vec2(v.x(), v.y()); }

}  // namespace

DetourResult plan_detour(const mpc::ReferenceTrajectory& reference, double t_s,
                         std::span<const world::Threat> threats, const world::Terrain& terrain,
                         const world::SafetyLimits& limits, const DetourOptions& o) {
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
    const double keep = threat.radius_m + limits.threat_margin_m + o.clearance_m;
    std::vector<Vec2> d(n);
    std::vector<bool> inside(n, false);
    int deepest = -1;
    double deepest_distance = keep;
    for (int j = 0; j < n; ++j) {
      if (!threat.active(times[j])) continue;
      d[j] = horizontal(base[j].position_m - threat.centre_at(times[j]));
      const double dist = d[j].norm();
      if (dist >= keep) continue;
      inside[j] = true;
      if (dist < deepest_distance) {
        deepest_distance = dist;
        deepest = j;
      }
    }
    if (deepest < 0) continue;
    conflict = true;
    // One side for the whole encounter, perpendicular to the reference where it comes closest
    // and away from the centre there: pushing along a fixed direction keeps the offsets smooth,
    // and flipping sides mid-encounter would cut through the threat.
    const double h = base[deepest].heading_rad;
    Vec2 side(-std::sin(h), std::cos(h));
    if (side.dot(d[deepest]) < 0.0) side = -side;
    // The push a ≥ 0 along `side` that puts the sample at `keep`: |d + a·side| = keep. Any larger
    // push keeps more distance (|d + a·side| grows for a ≥ −d·side), so dilating is safe.
    std::vector<double> need(n, 0.0);
    for (int j = 0; j < n; ++j) {
      if (!inside[j]) continue;
      const double along = d[j].dot(side);
      need[j] = -along + std::sqrt(std::max(0.0, along * along - d[j].squaredNorm() + keep * keep));
    }
    // Dilate in time: the offset may change by at most lateral_rate·|Δt|.
    for (int j = 0; j < n; ++j) {
      double offset = 0.0;
      for (int k = 0; k < n; ++k) {
        if (need[k] > 0.0)
          offset = std::max(offset, need[k] - o.lateral_rate_m_s * std::abs(times[j] - times[k]));
      }
      push[j] += offset * side;
    }
  }
  if (!conflict) return result;

  std::vector<Vec3> positions(n);
  for (int j = 0; j < n; ++j) {
    positions[j] = base[j].position_m;
    positions[j].head<2>() += push[j];
    const double floor = std::max(limits.altitude.min_m,
                                  terrain.height(positions[j].x(), positions[j].y()) +
                                      limits.terrain_clearance_m + terrain.model_error_m() + 5.0);
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
    if (positions[j].z() > limits.altitude.max_m) {
      result.status = DetourResult::Status::kFailed;
      result.message = fmt::format(
          "detour: at t = {:.1f} s it would need z = {:.1f} m, above the altitude limit {:.1f} m",
          times[j], positions[j].z(), limits.altitude.max_m);
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

std::optional<mpc::SampledReference> plan_reapproach_loop(double t_s, const Vec3& from_m,
                                                          double from_heading_rad,
                                                          const mpc::ReferencePoint& entry,
                                                          double radius_m, double speed_m_s,
                                                          const world::Terrain& terrain,
                                                          const world::SafetyLimits& limits) {
  const auto left = [](double h) { return Vec2(-std::sin(h), std::cos(h)); };
  const Vec2 p0 = horizontal(from_m), e = horizontal(entry.position_m);
  // Turn toward the entry's side: both turns the same way, so the loop closes on the track.
  const double side = left(from_heading_rad).dot(e - p0) >= 0.0 ? 1.0 : -1.0;  // +1: left
  const Vec2 c1 = p0 + side * radius_m * left(from_heading_rad);
  const Vec2 s2 = e + side * 2.0 * radius_m * left(entry.heading_rad);  // where turn 2 starts
  const Vec2 c2 = e + side * radius_m * left(entry.heading_rad);
  const Vec2 p1 = p0 + side * 2.0 * radius_m * left(from_heading_rad);  // where turn 1 ends
  const double arc = kPi * radius_m, straight = (s2 - p1).norm();
  const double length = 2.0 * arc + straight;
  const double step = 0.2;  // s
  const int n = std::max(3, static_cast<int>(std::ceil(length / speed_m_s / step)) + 1);
  std::vector<double> times(static_cast<std::size_t>(n));
  std::vector<Vec3> positions(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const double along = length * k / (n - 1);
    Vec2 q;
    if (along <= arc) {  // turn 1 about c1, from p0
      const double a = side * along / radius_m;
      const Vec2 r = p0 - c1;
      q = c1 + Vec2(std::cos(a) * r.x() - std::sin(a) * r.y(), std::sin(a) * r.x() + std::cos(a) * r.y());
    } else if (along <= arc + straight) {
      q = p1 + (s2 - p1) * ((along - arc) / std::max(straight, 1e-9));
    } else {  // turn 2 about c2, from s2
      const double a = side * (along - arc - straight) / radius_m;
      const Vec2 r = s2 - c2;
      q = c2 + Vec2(std::cos(a) * r.x() - std::sin(a) * r.y(), std::sin(a) * r.x() + std::cos(a) * r.y());
    }
    const double z = from_m.z() + (entry.position_m.z() - from_m.z()) * k / (n - 1);
    const double floor = terrain.height(q.x(), q.y()) + limits.terrain_clearance_m +
                         terrain.model_error_m() + 5.0;
    positions[static_cast<std::size_t>(k)] = Vec3(q.x(), q.y(), std::max(z, floor));
    if (!limits.altitude.contains(positions[static_cast<std::size_t>(k)].z())) return std::nullopt;
    times[static_cast<std::size_t>(k)] = t_s + length / speed_m_s * k / (n - 1);
  }
  return mpc::SampledReference::from_positions(times, positions);
}

}  // namespace ridgeline::swarm
