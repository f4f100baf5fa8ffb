#include "core/types.hpp"

#include <cmath>

namespace ridgeline {

double wrap_angle(double angle_rad) {
  // Already in (−π, π]: std::remainder would return the angle itself (no multiple of 2π is
  // nearer), and this is the common case of a heading difference; skip the library call.
  if (angle_rad > -kPi && angle_rad <= kPi) return angle_rad;
  double wrapped = std::remainder(angle_rad, 2.0 * kPi);
  // std::remainder returns values in [-pi, pi]; map -pi to pi so the range is half-open.
  if (wrapped <= -kPi) wrapped += 2.0 * kPi;
  return wrapped;
}

}  // namespace ridgeline
