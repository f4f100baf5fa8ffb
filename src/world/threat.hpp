// Sudden moving threats (DESIGN §4, paper eq. 13): spheres |p − c(t)| ≤ R with
// c(t) = c0 + v_T·(t − t_appear), existing only for t_appear ≤ t ≤ t_vanish.
#pragma once

#include <string>

#include "core/types.hpp"

namespace ridgeline::world {

struct Threat {
  std::string name;
  Vec3 centre_m = Vec3::Zero();      ///< c0: centre at t_appear
  Vec3 velocity_m_s = Vec3::Zero();  ///< v_T, constant
  double radius_m = 0.0;             ///< R, > 0
  double appear_s = 0.0;             ///< t_appear
  double vanish_s = 1e9;             ///< t_vanish, > t_appear
};

}  // namespace ridgeline::world
