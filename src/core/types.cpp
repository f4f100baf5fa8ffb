#include "core/types.hpp"

#include <cmath>

namespace ridgeline {

double wrap_angle_outside(double angle_rad) {
  // Within (−π, π] std::remainder returns the angle itself (no multiple of 2π is nearer), so
  // wrap_angle's shortcut gives the same values.
  double wrapped = std::remainder(angle_rad, 2.0 * kPi);
  // std::remainder returns values in [-pi, pi]; map -pi to pi so the range is half-open.
  if (wrapped <= -kPi) wrapped += 2.0 * kPi;
  return wrapped;
}

}  // namespace ridgeline
