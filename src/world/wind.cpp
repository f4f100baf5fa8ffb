#include "world/wind.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "core/error.hpp"
#include "core/simd_clones.hpp"
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
  for (std::vector<double>* v :
       {&wave_x_, &wave_y_, &wave_z_, &angular_frequency_, &cos_phase_[0], &cos_phase_[1],
        &cos_phase_[2], &sin_phase_[0], &sin_phase_[1], &sin_phase_[2]}) {
    v->reserve(static_cast<std::size_t>(n));
  }
  for (int i = 0; i < n; ++i) {
    // Draw order is part of the reproducibility contract: k (x, y, z), ω, phases (x, y, z).
    wave_x_.push_back(rng.normal(0.0, inv_length));
    wave_y_.push_back(rng.normal(0.0, inv_length));
    wave_z_.push_back(rng.normal(0.0, inv_length));
    angular_frequency_.push_back(rng.normal(0.0, inv_time));
    for (int c = 0; c < 3; ++c) {
      const double phase = rng.uniform(0.0, 2.0 * kPi);
      cos_phase_[c].push_back(std::cos(phase));
      sin_phase_[c].push_back(std::sin(phase));
    }
  }
}

// Without fused multiply-adds (RIDGELINE_NO_CONTRACTION), so that the AVX2 clone rounds as the
// baseline one does and a field's values depend on the machine through sin_cos alone.
RIDGELINE_SIMD_CLONES RIDGELINE_NO_CONTRACTION Vec3 WindField::gust_at(const Vec3& p_m,
                                                                       double t_s) const {
  if (config_.gust_std_m_s == 0.0) return Vec3::Zero();
  double theta[kModeBatch], sin_theta[kModeBatch], cos_theta[kModeBatch];
  const int n = static_cast<int>(wave_x_.size());
  const double px = p_m.x(), py = p_m.y(), pz = p_m.z();
  double sx = 0.0, sy = 0.0, sz = 0.0;
  for (int begin = 0; begin < n; begin += kModeBatch) {
    const int count = std::min(kModeBatch, n - begin);
    // θ_n = k_n·p − ω_n t, the dot product summed x, y, z in that order (element-wise over the
    // modes, so the compiler's vector code gives the same values).
    const double* kx = wave_x_.data() + begin;
    const double* ky = wave_y_.data() + begin;
    const double* kz = wave_z_.data() + begin;
    const double* omega = angular_frequency_.data() + begin;
    for (int i = 0; i < count; ++i) {
      theta[i] = kx[i] * px + ky[i] * py + kz[i] * pz - omega[i] * t_s;
    }
    sin_cos(theta, sin_theta, cos_theta, count);
    // Σ cos(θ_n + φ_{n,c}), eq. W1, in four interleaved partial sums a component (mode n in
    // lane n mod 4 of its batch), combined pairwise at the batch's end: the compiler keeps each
    // lane in a vector register instead of three chains of one addition a mode, and the order is
    // written out, so every machine sums the same way.
    const double* cx = cos_phase_[0].data() + begin;
    const double* cy = cos_phase_[1].data() + begin;
    const double* cz = cos_phase_[2].data() + begin;
    const double* sxp = sin_phase_[0].data() + begin;
    const double* syp = sin_phase_[1].data() + begin;
    const double* szp = sin_phase_[2].data() + begin;
    Vec4 lx = {}, ly = {}, lz = {};
    const auto add_modes = [&](const double* c_theta, const double* s_theta, const double* ax_,
                               const double* ay_, const double* az_, const double* bx_,
                               const double* by_, const double* bz_)
        __attribute__((always_inline)) {
      Vec4 c, s, ax, ay, az, bx, by, bz;
      std::memcpy(&c, c_theta, sizeof c);
      std::memcpy(&s, s_theta, sizeof s);
      std::memcpy(&ax, ax_, sizeof ax);
      std::memcpy(&ay, ay_, sizeof ay);
      std::memcpy(&az, az_, sizeof az);
      std::memcpy(&bx, bx_, sizeof bx);
      std::memcpy(&by, by_, sizeof by);
      std::memcpy(&bz, bz_, sizeof bz);
      lx += c * ax - s * bx;
      ly += c * ay - s * by;
      lz += c * az - s * bz;
    };
    int i = 0;
    for (; i + 4 <= count; i += 4) {
      add_modes(cos_theta + i, sin_theta + i, cx + i, cy + i, cz + i, sxp + i, syp + i, szp + i);
    }
    if (i < count) {
      // The last one to three modes, padded with cos θ = sin θ = 0: the padding adds zeros.
      double pad[8][4] = {};
      const double* from[8] = {cos_theta, sin_theta, cx, cy, cz, sxp, syp, szp};
      for (int a = 0; a < 8; ++a) std::copy(from[a] + i, from[a] + count, pad[a]);
      add_modes(pad[0], pad[1], pad[2], pad[3], pad[4], pad[5], pad[6], pad[7]);
    }
    sx += (lx[0] + lx[1]) + (lx[2] + lx[3]);
    sy += (ly[0] + ly[1]) + (ly[2] + ly[3]);
    sz += (lz[0] + lz[1]) + (lz[2] + lz[3]);
  }
  return Vec3(amplitude_.x() * sx, amplitude_.y() * sy, amplitude_.z() * sz);
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
