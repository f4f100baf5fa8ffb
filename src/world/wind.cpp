#include "world/wind.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.hpp"
#include "core/sin_cos.hpp"

namespace ridgeline::world {
namespace {

std::string field_path(std::string_view prefix, std::string_view field) {
  if (prefix.empty()) return std::string(field);
  return fmt::format("{}.{}", prefix, field);
}

void require_finite_non_negative(double value, std::string_view prefix, std::string_view field) {
  if (!std::isfinite(value)) {
    throw InputError(field_path(prefix, field), fmt::format("must be finite, got {}", value));
  }
  if (value < 0.0) {
    throw InputError(field_path(prefix, field), fmt::format("must be >= 0, got {}", value));
  }
}

void require_finite_positive(double value, std::string_view prefix, std::string_view field) {
  if (!std::isfinite(value)) {
    throw InputError(field_path(prefix, field), fmt::format("must be finite, got {}", value));
  }
  if (value <= 0.0) {
    throw InputError(field_path(prefix, field), fmt::format("must be > 0, got {}", value));
  }
}

// Gust modes evaluated a batch at a time (on the stack). The wind field is evaluated at every
// 5 ms truth step of every UAV (64 modes by default), where libm's scalar sincos was a tenth of
// a simulated flight's instructions: core/sin_cos.hpp takes four angles a call.
constexpr int kModeBatch = 64;

}  // namespace

void validate(const WindConfig& config, std::string_view field_prefix) {
  if (!config.mean_m_s.allFinite()) {
    throw InputError(field_path(field_prefix, "mean_m_s"),
                     fmt::format("must be finite, got [{}, {}, {}]", config.mean_m_s.x(),
                                 config.mean_m_s.y(), config.mean_m_s.z()));
  }
  require_finite_non_negative(config.gust_std_m_s, field_prefix, "gust_std_m_s");
  require_finite_non_negative(config.vertical_gust_ratio, field_prefix, "vertical_gust_ratio");
  require_finite_positive(config.correlation_length_m, field_prefix, "correlation_length_m");
  require_finite_positive(config.correlation_time_s, field_prefix, "correlation_time_s");
  require_finite_non_negative(config.measurement_noise_m_s, field_prefix, "measurement_noise_m_s");
  if (config.gust_modes < 1 || config.gust_modes > kMaxGustModes) {
    throw InputError(field_path(field_prefix, "gust_modes"),
                     fmt::format("must be in [1, {}], got {}", kMaxGustModes, config.gust_modes));
  }
}

WindField::WindField(const WindConfig& config) : config_(config) {
  validate(config_, "wind");
  const double sigma_h = config_.gust_std_m_s;
  gust_std_ = Vec3(sigma_h, sigma_h, config_.vertical_gust_ratio * sigma_h);
  const int n = config_.gust_modes;
  amplitude_ = gust_std_ * std::sqrt(2.0 / n);

  // eq. W2: k ~ N(0, I/L²) and ω ~ N(0, 1/T²) make E[cos(k·r − ωτ)] the Gaussian correlation.
  Rng rng(derive_seed(config_.seed, kWindFieldStream));
  const double inv_length = 1.0 / config_.correlation_length_m;
  const double inv_time = 1.0 / config_.correlation_time_s;
  modes_.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    Mode mode;
    // Draw order is part of the reproducibility contract: k (x, y, z), ω, phases (x, y, z).
    const double kx = rng.normal(0.0, inv_length);
    const double ky = rng.normal(0.0, inv_length);
    const double kz = rng.normal(0.0, inv_length);
    mode.wave_vector_rad_m = Vec3(kx, ky, kz);
    mode.angular_frequency_rad_s = rng.normal(0.0, inv_time);
    for (int c = 0; c < 3; ++c) {
      const double phase = rng.uniform(0.0, 2.0 * kPi);
      mode.cos_phase[c] = std::cos(phase);
      mode.sin_phase[c] = std::sin(phase);
    }
    modes_.push_back(mode);
  }
}

Vec3 WindField::gust_at(const Vec3& p_m, double t_s) const {
  if (config_.gust_std_m_s == 0.0) return Vec3::Zero();
  Vec3 sum = Vec3::Zero();
  double theta[kModeBatch], sin_theta[kModeBatch], cos_theta[kModeBatch];
  const int n = static_cast<int>(modes_.size());
  for (int begin = 0; begin < n; begin += kModeBatch) {
    const int count = std::min(kModeBatch, n - begin);
    for (int i = 0; i < count; ++i) {
      const Mode& mode = modes_[static_cast<std::size_t>(begin + i)];
      theta[i] = mode.wave_vector_rad_m.dot(p_m) - mode.angular_frequency_rad_s * t_s;
    }
    sin_cos(theta, sin_theta, cos_theta, count);
    for (int i = 0; i < count; ++i) {
      const Mode& mode = modes_[static_cast<std::size_t>(begin + i)];
      // cos(θ + φ_c), eq. W1
      sum += cos_theta[i] * mode.cos_phase - sin_theta[i] * mode.sin_phase;
    }
  }
  return amplitude_.cwiseProduct(sum);
}

Vec3 WindField::at(const Vec3& p_m, double t_s) const {
  return config_.mean_m_s + gust_at(p_m, t_s);
}

double WindField::gust_bound_m_s(double n_sigma) const { return n_sigma * gust_std_.norm(); }

double WindField::correlation(double lag_s, double displacement_m) const {
  const double r = displacement_m / config_.correlation_length_m;
  const double tau = lag_s / config_.correlation_time_s;
  return std::exp(-0.5 * (r * r + tau * tau));
}

double WindField::gust_change_bound_m_s(double lag_s, double displacement_m, double n_sigma) const {
  // Var[g_c(p + r, t + τ) − g_c(p, t)] = 2σ_c²(1 − ρ(r, τ)) by eq. W2.
  const double rho = correlation(lag_s, displacement_m);
  return n_sigma * std::sqrt(2.0 * (1.0 - rho)) * gust_std_.norm();
}

WindSensor::WindSensor(const WindConfig& config, std::uint64_t sensor_id)
    : noise_std_m_s_(config.measurement_noise_m_s),
      rng_(derive_seed(derive_seed(config.seed, kWindSensorStream), sensor_id)) {
  validate(config, "wind");
}

Vec3 WindSensor::corrupt(const Vec3& true_wind_m_s) {
  const double nx = rng_.normal(0.0, noise_std_m_s_);
  const double ny = rng_.normal(0.0, noise_std_m_s_);
  const double nz = rng_.normal(0.0, noise_std_m_s_);
  return true_wind_m_s + Vec3(nx, ny, nz);
}

Vec3 WindSensor::measure(const WindField& field, const Vec3& p_m, double t_s) {
  return corrupt(field.at(p_m, t_s));
}

double WindSensor::error_bound_m_s(double n_sigma) const {
  return n_sigma * std::sqrt(3.0) * noise_std_m_s_;
}

}  // namespace ridgeline::world
