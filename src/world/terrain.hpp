// Terrain height fields H(x, y) over the ENU plane (DESIGN §4, paper eq. 12).
//
// Heights are metres above the scenario's terrain datum, the same datum as the UAVs' z.
// Every terrain offers its height and its analytic gradient; planners and the MPC's
// linearized clearance constraint (DESIGN §3) use both.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "world/raster_grid.hpp"

namespace ridgeline::world {

/// Interface of every terrain model. Implementations are immutable and thread-safe.
class Terrain {
 public:
  virtual ~Terrain() = default;
  /// Height H(x, y) in metres.
  virtual double height(double x_m, double y_m) const = 0;
  /// Gradient (dH/dx, dH/dy), dimensionless (m/m).
  virtual Vec2 gradient(double x_m, double y_m) const = 0;
  /// Height and gradient at one point, equal to height() and gradient(): for the MPC's
  /// clearance rows, which need both at every predicted position of every step. The default
  /// calls the two; a model that finds both from the same work overrides it.
  virtual double height_and_gradient(double x_m, double y_m, Vec2& gradient_out) const;
  /// height_and_gradient at each column j of `positions_m` (x and y its first two rows, any
  /// others not read): heights_m[j] and gradients[j], equal to it bit for bit. The MPC's step
  /// reads the terrain at its Np predicted positions at once; a model that takes several
  /// together overrides it, and this one asks height_and_gradient for each. Throws
  /// std::invalid_argument unless both spans have one entry a column and there are ≥ 2 rows.
  virtual void heights_and_gradients(const Eigen::Ref<const Eigen::MatrixXd>& positions_m,
                                     std::span<double> heights_m, std::span<Vec2> gradients) const;
  /// Hessian of H (1/m). The default is central differences of gradient() at 1 mm, symmetrized;
  /// a model with an analytic one overrides it.
  virtual Eigen::Matrix2d hessian(double x_m, double y_m) const;
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

/// Throws InputError unless every peak has finite x/y, finite positive height and sigmas,
/// and the base elevation and model error are finite (model error also >= 0). Field paths
/// are rooted at `path`, e.g. `terrain.peaks[3].sigma_x_m`.
void validate_peak_terrain_config(const PeakTerrainConfig& config,
                                  const std::string& path = "terrain");

/// The analytic peak field of eq. 12:
///   max:  H(x, y) = H0 + max_i h_i·e_i(x, y)
///   sum:  H(x, y) = H0 + Σ_i  h_i·e_i(x, y),   e_i = exp(−((x − x_i)/a_i)² − ((y − y_i)/b_i)²)
/// with base elevation H0. The gradient is analytic: ∂(h·e)/∂x = −2 h·e·(x − x_i)/a_i²
/// (likewise in y). For `max` it is the gradient of the dominant peak (the one attaining the
/// max; the lowest index on a tie) — H is not differentiable where two peaks are equal, and
/// this one-sided choice is what the MPC's linearized clearance row needs. With no peaks the
/// field is the flat plane H0.
class PeakTerrain : public Terrain {
 public:
  /// Validates the config (validate_peak_terrain_config with root `path`).
  explicit PeakTerrain(PeakTerrainConfig config, const std::string& path = "terrain");

  double height(double x_m, double y_m) const override;
  Vec2 gradient(double x_m, double y_m) const override;
  /// One pass over the peaks (one dominant-peak search for `max`).
  double height_and_gradient(double x_m, double y_m, Vec2& gradient_out) const override;
  /// For `max`, the dominant peaks of four positions at a time (one a lane, branch-free).
  void heights_and_gradients(const Eigen::Ref<const Eigen::MatrixXd>& positions_m,
                             std::span<double> heights_m, std::span<Vec2> gradients) const override;
  double model_error_m() const override { return config_.model_error_m; }

  const PeakTerrainConfig& config() const { return config_; }

 private:
  /// For `max`: the dominant peak at (x, y) and its value h·e (nullptr without peaks). It
  /// compares ln h_i − q_i, q_i the exponent, so one exp is taken instead of one per peak; the
  /// same peak as comparing the values h_i·e_i except where two differ by round-off.
  /// The scores and their maximum are taken in one pass over the columns below (four peaks at
  /// a time, with the widths' reciprocals; the lowest index on a tie); the exponent of the
  /// chosen peak is then computed as in height(), so the value does not depend on that pass's
  /// round-off.
  const Peak* dominant(double x_m, double y_m, double* value) const;

  PeakTerrainConfig config_;
  std::vector<double> log_height_;  ///< ln h_i
  // The peaks' fields as columns, for dominant()'s vector loop.
  std::vector<double> peak_x_, peak_y_, peak_inv_sigma_x_, peak_inv_sigma_y_;
};

/// A raster terrain: bilinear interpolation of a RasterGrid (see raster_grid.hpp for the
/// cell-centre / row-0-south convention).
///
/// Inside the hull of the cell centres, with u = (x − x_c)/Δx, v = (y − y_r)/Δy in [0, 1]:
///   H = (1−u)(1−v)·H_00 + u(1−v)·H_01 + (1−u)v·H_10 + uv·H_11,
///   ∂H/∂x = ((1−v)(H_01 − H_00) + v(H_11 − H_10))/Δx   (likewise in y).
/// The gradient is that of the cell containing the point (the cell to the north/east on a
/// shared edge); H itself is continuous.
/// Points outside the hull are CLAMPED to the border: x and y are each clamped to the range of
/// cell-centre coordinates, so the field extends as constant along the outward normal, and the
/// gradient component across a clamped axis is zero. A grid of one row (or column) is
/// constant in y (or x).
class RasterTerrain : public Terrain {
 public:
  /// Validates the grid (validate_raster_grid with `what` as the error's field).
  explicit RasterTerrain(RasterGrid grid, double model_error_m = 0.0,
                         const std::string& what = "terrain.raster");

  double height(double x_m, double y_m) const override;
  Vec2 gradient(double x_m, double y_m) const override;
  /// One cell look-up for both (the MPC's clearance rows on a DEM).
  double height_and_gradient(double x_m, double y_m, Vec2& gradient_out) const override;
  double model_error_m() const override { return model_error_m_; }

  const RasterGrid& grid() const { return grid_; }

 private:
  struct Cell {
    int row = 0;
    int col = 0;
    double u = 0.0;  ///< fractional position east of col, in [0, 1]
    double v = 0.0;  ///< fractional position north of row, in [0, 1]
    bool clamped_x = false;
    bool clamped_y = false;
  };
  Cell locate(double x_m, double y_m) const;
  /// The cell at (x, y) and its four corner heights (h_rc: row r, column c, from its
  /// south-west corner), and the bilinear height and gradient over them.
  struct Patch {
    Cell cell;
    double h00 = 0.0, h01 = 0.0, h10 = 0.0, h11 = 0.0;
  };
  Patch patch(double x_m, double y_m) const;
  static double patch_height(const Patch& p);
  Vec2 patch_gradient(const Patch& p) const;

  RasterGrid grid_;
  double model_error_m_ = 0.0;
};

/// Samples `terrain` at the cell centres of a rows × cols grid whose south-west cell centre is
/// `origin_m` and whose spacing is `cell_m` (x, y). Throws InputError on a bad geometry.
RasterGrid sample_terrain(const Terrain& terrain, int rows, int cols, const Vec2& origin_m,
                          const Vec2& cell_m);

}  // namespace ridgeline::world
