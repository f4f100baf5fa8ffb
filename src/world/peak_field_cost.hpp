// The least-squares residual of the terrain fit (terrain_fit.hpp) with analytic Jacobians.
//
// An implementation detail of fit_peak_terrain, in its own header so tests can check its
// Jacobians against finite differences. Not part of the terrain API.
//
// Residual of sample s: r_s = H0 + C({v_i}) − z_s, with v_i = h_i·e_i(x_s, y_s) of eq. 12 and
// C the sum, the exact max, or the soft-max  m + (1/β)·log Σ_i exp(β(v_i − m)),  m = max_i v_i.
// ∂C/∂v_i is 1 (sum), the indicator of the dominant peak (max), or the softmax weight
// exp(β(v_i − m))/Σ_j exp(β(v_j − m)); and
//   ∂v/∂x_i = 2v(x − x_i)/a²,  ∂v/∂y_i = 2v(y − y_i)/b²,  ∂v/∂h = e,
//   ∂v/∂a = 2v(x − x_i)²/a³,   ∂v/∂b = 2v(y − y_i)²/b³.
#pragma once

#include <ceres/cost_function.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace ridgeline::world::fit_detail {

/// Parameters of one peak block, in this order: x_i, y_i (m), h_i (m), a_i, b_i (m).
constexpr int kPeakParams = 5;

/// How the residual combines the peaks: their sum, the soft-max (log-sum-exp with sharpness
/// β, 1/m) or the exact max with the dominant peak's Jacobian.
enum class Combine { kSum, kSoftMax, kHardMax };

/// Raster samples in the fit's coordinates (x, y in m, relative to the raster's centre; z in m).
struct Samples {
  std::vector<double> x, y, z;
};

// Residuals H_θ(x_s, y_s) − z_s of a contiguous block of samples, with analytic Jacobians.
// Parameter blocks: [H0] then one [x, y, h, a, b] per peak.
class PeakFieldCost final : public ceres::CostFunction {
 public:
  PeakFieldCost(const Samples* samples, int begin, int count, int num_peaks, Combine combine,
                double beta)
      : samples_(samples), begin_(begin), num_peaks_(num_peaks), combine_(combine), beta_(beta) {
    set_num_residuals(count);
    mutable_parameter_block_sizes()->push_back(1);
    for (int i = 0; i < num_peaks; ++i) mutable_parameter_block_sizes()->push_back(kPeakParams);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int n = num_residuals();
    std::vector<double> value(static_cast<std::size_t>(num_peaks_));
    std::vector<double> weight(static_cast<std::size_t>(num_peaks_));
    for (int s = 0; s < n; ++s) {
      const auto k = static_cast<std::size_t>(begin_ + s);
      const double x = samples_->x[k];
      const double y = samples_->y[k];
      double vmax = -std::numeric_limits<double>::infinity();
      int imax = 0;
      for (int i = 0; i < num_peaks_; ++i) {
        const double* p = parameters[1 + i];
        const double dx = (x - p[0]) / p[3];
        const double dy = (y - p[1]) / p[4];
        value[i] = p[2] * std::exp(-(dx * dx + dy * dy));
        if (value[i] > vmax) {
          vmax = value[i];
          imax = i;
        }
      }
      double field = 0.0;
      switch (combine_) {
        case Combine::kSum:
          for (int i = 0; i < num_peaks_; ++i) {
            field += value[i];
            weight[i] = 1.0;
          }
          break;
        case Combine::kHardMax:
          field = vmax;
          std::fill(weight.begin(), weight.end(), 0.0);
          weight[imax] = 1.0;
          break;
        case Combine::kSoftMax: {
          // Shifted by the max so no exp overflows; d(softmax)/dv_i = exp(β(v_i − m))/S.
          double sum = 0.0;
          for (int i = 0; i < num_peaks_; ++i) {
            weight[i] = std::exp(beta_ * (value[i] - vmax));
            sum += weight[i];
          }
          for (int i = 0; i < num_peaks_; ++i) weight[i] /= sum;
          field = vmax + std::log(sum) / beta_;
          break;
        }
      }
      residuals[s] = parameters[0][0] + field - samples_->z[k];
      if (jacobians == nullptr) continue;
      if (jacobians[0] != nullptr) jacobians[0][s] = 1.0;
      for (int i = 0; i < num_peaks_; ++i) {
        double* J = jacobians[1 + i];
        if (J == nullptr) continue;
        const double* p = parameters[1 + i];
        const double w = weight[i] * value[i];
        const double rx = x - p[0];
        const double ry = y - p[1];
        const double a2 = p[3] * p[3];
        const double b2 = p[4] * p[4];
        double* row = J + static_cast<std::ptrdiff_t>(s) * kPeakParams;
        row[0] = 2.0 * w * rx / a2;
        row[1] = 2.0 * w * ry / b2;
        row[2] = p[2] != 0.0 ? w / p[2] : weight[i] * std::exp(-(rx * rx / a2 + ry * ry / b2));
        row[3] = 2.0 * w * rx * rx / (a2 * p[3]);
        row[4] = 2.0 * w * ry * ry / (b2 * p[4]);
      }
    }
    return true;
  }

 private:
  const Samples* samples_;
  int begin_;
  int num_peaks_;
  Combine combine_;
  double beta_;
};

}  // namespace ridgeline::world::fit_detail
