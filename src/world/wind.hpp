// Wind field: mean vector plus spatially and temporally correlated gusts (DESIGN §4).
#pragma once

#include <cstdint>

#include "core/types.hpp"

namespace ridgeline::world {

struct WindConfig {
  Vec3 mean_m_s = Vec3::Zero();       ///< mean wind vector (ENU), m/s
  double gust_std_m_s = 0.0;          ///< standard deviation of each horizontal gust component
  double vertical_gust_ratio = 0.3;   ///< vertical gust std as a fraction of the horizontal one
  double correlation_length_m = 200;  ///< spatial correlation length of the gusts
  double correlation_time_s = 10.0;   ///< temporal correlation time of the gusts
  double measurement_noise_m_s = 0.2; ///< std of each component of an anemometer reading
  std::uint64_t seed = 1;
};

}  // namespace ridgeline::world
