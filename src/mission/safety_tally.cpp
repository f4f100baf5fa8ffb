#include "mission/safety_tally.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ridgeline::mission {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

SafetyTally::SafetyTally(const world::SafetyLimits& limits, int num_uavs,
                         const world::Terrain& terrain)
    : terrain_(terrain),
      separation_m_(limits.separation_m),
      threat_margin_m_(limits.threat_margin_m),
      min_clearance_m_(static_cast<std::size_t>(num_uavs), kInf),
      min_separation_m_(kInf),
      min_threat_m_(kInf) {}

void SafetyTally::sensed(int uav, int threat, double t, const TruthWorld& world) {
  if (!encounters_.insert({uav, threat}).second) return;
  escapes_[{uav, threat}] =
      assess_escape(world.true_state(uav), world.true_wind(uav), world.truth_params(uav),
                    world.threats()[static_cast<std::size_t>(threat)], t);
}

void SafetyTally::sample(double t, const TruthWorld& world) {
  const int n = world.num_uavs();
  for (int i = 0; i < n; ++i) {
    const Vec3 p = world.true_position(i);
    double& clearance = min_clearance_m_[static_cast<std::size_t>(i)];
    clearance = std::min(clearance, p.z() - terrain_.height(p.x(), p.y()));
    for (int j = i + 1; j < n; ++j) {
      const Vec3 now = p - world.true_position(j);
      double d = now.norm(), when = t;
      if (!previous_positions_.empty()) {
        // Closest approach of the relative motion, straight from the previous sample to this.
        const Vec3 before = previous_positions_[static_cast<std::size_t>(i)] -
                            previous_positions_[static_cast<std::size_t>(j)];
        const Vec3 change = now - before;
        const double c2 = change.squaredNorm();
        const double s = c2 > 0.0 ? std::clamp(-before.dot(change) / c2, 0.0, 1.0) : 1.0;
        const double between = (before + s * change).norm();
        if (between < d) {
          d = between;
          when = previous_time_s_ + s * (t - previous_time_s_);
        }
      }
      if (d < min_separation_m_) {
        min_separation_m_ = d;
        closest_pair_ = {i, j};
        closest_time_s_ = when;
      }
      if (d < separation_m_) close_pairs_.insert({i, j});
    }
    for (std::size_t k = 0; k < world.threats().size(); ++k) {
      const double d = world.threats()[k].surface_distance(p, t);
      if (!std::isfinite(d)) continue;
      min_threat_m_ = std::min(min_threat_m_, d);
      if (d < 0.0) intrusions_.insert({i, static_cast<int>(k)});
      if (d < threat_margin_m_) margin_violations_.insert({i, static_cast<int>(k)});
    }
  }
  previous_positions_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) previous_positions_[static_cast<std::size_t>(i)] = world.true_position(i);
  previous_time_s_ = t;
}

void SafetyTally::write(MissionMetrics& m) const {
  m.min_separation_m = min_separation_m_;
  m.min_separation_pair = closest_pair_;
  m.min_separation_time_s = closest_time_s_;
  m.min_threat_distance_m = min_threat_m_;
  std::set<std::pair<int, int>> encounters = encounters_;
  encounters.insert(intrusions_.begin(), intrusions_.end());
  m.threat_encounters = static_cast<int>(encounters.size());
  m.threat_intrusions = static_cast<int>(intrusions_.size());
  m.unavoidable_intrusions = 0;
  m.unavoidable_intrusion_contact_s.clear();
  for (const auto& pair : intrusions_) {
    const auto it = escapes_.find(pair);
    if (it == escapes_.end() || !it->second.unavoidable) continue;
    ++m.unavoidable_intrusions;
    m.unavoidable_intrusion_contact_s.push_back(it->second.time_to_contact_s);
  }
  m.avoidable_intrusions = m.threat_intrusions - m.unavoidable_intrusions;
  m.threat_margin_violations = static_cast<int>(margin_violations_.size());
  m.avoidance_success_rate = encounters.empty()
                                 ? 1.0
                                 : static_cast<double>(m.threat_encounters - m.threat_intrusions) /
                                       static_cast<double>(m.threat_encounters);
  m.separation_violations = static_cast<int>(close_pairs_.size());
  m.terrain_collisions = 0;
  for (std::size_t i = 0; i < m.uavs.size() && i < min_clearance_m_.size(); ++i) {
    m.uavs[i].min_terrain_clearance_m = min_clearance_m_[i];
    if (min_clearance_m_[i] < 0.0) ++m.terrain_collisions;
  }
}

}  // namespace ridgeline::mission
