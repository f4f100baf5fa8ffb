#include "sim/variation.hpp"

#include <algorithm>
#include <cmath>

#include "core/random.hpp"

namespace ridgeline::sim {

std::uint64_t variation_seed(const mission::Scenario& scenario, int index) {
  // Small, readable seeds: the scenario's seed times 100000 plus the run index.
  return scenario.seed * 100000ULL + static_cast<std::uint64_t>(index) + 1ULL;
}

mission::Scenario vary_scenario(const mission::Scenario& scenario, const world::Terrain& terrain,
                                std::uint64_t seed, const VariationOptions& o) {
  mission::Scenario s = scenario;
  s.seed = seed;
  Rng rng(derive_seed(seed, 1));
  for (world::Threat& th : s.threats) {
    th.centre_m.x() += rng.uniform(-o.threat_shift_m, o.threat_shift_m);
    th.centre_m.y() += rng.uniform(-o.threat_shift_m, o.threat_shift_m);
    th.centre_m.z() += rng.uniform(-o.threat_shift_m / 3.0, o.threat_shift_m / 3.0);
    th.velocity_m_s.x() += rng.uniform(-o.threat_speed_m_s, o.threat_speed_m_s);
    th.velocity_m_s.y() += rng.uniform(-o.threat_speed_m_s, o.threat_speed_m_s);
    const double lifetime = th.vanish_s - th.appear_s;
    th.appear_s = std::max(0.0, th.appear_s + rng.uniform(-o.threat_time_s, o.threat_time_s));
    th.vanish_s = th.appear_s + lifetime;
  }
  s.wind.seed = derive_seed(seed, 2);
  const double angle = rng.uniform(-o.wind_direction_rad, o.wind_direction_rad);
  const double scale = 1.0 + rng.uniform(-o.wind_speed_fraction, o.wind_speed_fraction);
  const Vec3 w = s.wind.mean_m_s;
  s.wind.mean_m_s = Vec3(scale * (std::cos(angle) * w.x() - std::sin(angle) * w.y()),
                         scale * (std::sin(angle) * w.x() + std::cos(angle) * w.y()), w.z());
  for (std::size_t i = 0; i < s.uavs.size(); ++i) {
    const mission::UavSpec original = s.uavs[i];
    for (int attempt = 0; attempt < 20; ++attempt) {
      s.uavs[i].start_position_m.x() =
          original.start_position_m.x() + rng.uniform(-o.start_jitter_m, o.start_jitter_m);
      s.uavs[i].start_position_m.y() =
          original.start_position_m.y() + rng.uniform(-o.start_jitter_m, o.start_jitter_m);
      s.uavs[i].start_heading_rad =
          original.start_heading_rad + rng.uniform(-o.start_heading_rad, o.start_heading_rad);
      if (validate(s, terrain).empty()) break;
      s.uavs[i] = original;
    }
  }
  return s;
}

}  // namespace ridgeline::sim
