// Terrain height fields H(x, y) over the ENU plane (DESIGN §4, paper eq. 12).
//
// Heights are metres above the scenario's terrain datum, the same datum as the UAVs' z.
// Every terrain offers its height and its analytic gradient; planners and the MPC's
// linearized clearance constraint (DESIGN §3) use both.
#pragma once

#include <memory>
#include <vector>

#include "core/types.hpp"

namespace ridgeline::world {

/// Interface of every terrain model. Implementations are immutable and thread-safe.
class Terrain {
 public:
  virtual ~Terrain() = default;
  /// Height H(x, y) in metres.
  virtual double height(double x_m, double y_m) const = 0;
  /// Gradient (dH/dx, dH/dy), dimensionless (m/m).
  virtual Vec2 gradient(double x_m, double y_m) const = 0;
  /// Extra margin (m) a consumer should add to its clearance because the model is an
  /// approximation of the real ground (e.g. a fitted field's max residual). Zero if exact.
  virtual double model_error_m() const { return 0.0; }
};

/// One Gaussian-shaped peak of eq. 12: h·exp(−((x−x0)/a)² − ((y−y0)/b)²).
struct Peak {
  double x_m = 0.0;
  double y_m = 0.0;
  double height_m = 0.0;   ///< h_i, > 0
  double sigma_x_m = 1.0;  ///< a_i, > 0
  double sigma_y_m = 1.0;  ///< b_i, > 0
};

/// How the peaks combine: the paper's `max` (eq. 12) or their `sum`.
enum class PeakCombination { kMax, kSum };

struct PeakTerrainConfig {
  std::vector<Peak> peaks;
  PeakCombination combination = PeakCombination::kMax;
  double base_elevation_m = 0.0;  ///< added to the peak field everywhere
  double model_error_m = 0.0;     ///< known error of this field (e.g. a fit's max residual)
};

}  // namespace ridgeline::world
