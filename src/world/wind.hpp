// Wind field: mean vector plus spatially and temporally correlated gusts (DESIGN §4).
//
// The wind at ENU position p (m) and time t (s) is
//
//   W(p, t) = W̄ + g(p, t),   g_c(p, t) = A_c · Σ_{n=1..N} cos(k_n·p − ω_n t + φ_{n,c}),   (W1)
//
// a sum of N random Fourier modes (c = x, y, z). Each mode has a wave vector
// k_n ~ N(0, I/L²) (rad/m), an angular frequency ω_n ~ N(0, 1/T²) (rad/s) and, per
// component, a phase φ_{n,c} ~ U[0, 2π). Over the random draw of the modes the gusts are a
// zero-mean field with the separable Gaussian correlation
//
//   E[g_c(p, t) g_c(p + r, t + τ)] = σ_c² · exp(−|r|²/(2L²) − τ²/(2T²)),                  (W2)
//
// because E[cos(k·r − ωτ)] is the characteristic function of the Gaussian spectrum. L is
// `correlation_length_m`, T is `correlation_time_s`. The amplitudes A_c = σ_c·√(2/N) make
// each component's variance exactly σ_c² in every realization (a cosine with a uniform phase
// has variance 1/2), with σ_x = σ_y = `gust_std_m_s` and σ_z = `vertical_gust_ratio`·σ_x;
// by the central limit theorem the field is close to Gaussian for N ≳ 30.
//
// The three components share each mode's k_n and ω_n but have independent phases, so one
// sin/cos pair a mode serves all three (evaluation costs 2N trigonometric calls). Their
// ensemble cross-correlation is zero; a single realization keeps a residual cross-correlation
// of order 1/√(2N) (≈ 0.09 for the default N = 64), which is harmless for a disturbance.
//
// Everything is drawn from ridgeline::Rng seeded with derive_seed(seed, kWindFieldStream),
// so a field is reproducible from its config on every platform.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "core/random.hpp"
#include "core/types.hpp"

namespace ridgeline::world {

struct WindConfig {
  Vec3 mean_m_s = Vec3::Zero();        ///< mean wind vector (ENU), m/s
  double gust_std_m_s = 0.0;           ///< standard deviation of each horizontal gust component
  double vertical_gust_ratio = 0.3;    ///< vertical gust std as a fraction of the horizontal one
  double correlation_length_m = 200;   ///< spatial correlation length of the gusts
  double correlation_time_s = 10.0;    ///< temporal correlation time of the gusts
  double measurement_noise_m_s = 0.2;  ///< std of each component of an anemometer reading
  std::uint64_t seed = 1;
  int gust_modes = 64;  ///< N in eq. W1, in [1, kMaxGustModes]
};

/// Upper limit of WindConfig::gust_modes: more modes only cost time.
constexpr int kMaxGustModes = 4096;

/// Sub-stream ids passed to derive_seed(WindConfig::seed, ·): the field and the sensors
/// draw from unrelated sequences, and sensor i uses derive_seed(sensor stream seed, i).
constexpr std::uint64_t kWindFieldStream = 0x57494E44;   // "WIND"
constexpr std::uint64_t kWindSensorStream = 0x414E454D;  // "ANEM"

/// Throws ridgeline::InputError naming `<field_prefix>.<field>` (e.g. `wind.gust_std_m_s`) if
/// a value is non-finite, a std or ratio is negative, a correlation length or time is not
/// positive, or gust_modes is outside [1, kMaxGustModes].
void validate(const WindConfig& config, std::string_view field_prefix = "wind");

/// The truth wind field W(p, t) of eq. W1. Immutable after construction, so one field may be
/// queried by several simulated UAVs and threads; at() does not allocate.
class WindField {
 public:
  /// Validates `config` (field prefix `wind`) and draws the modes from its seed.
  explicit WindField(const WindConfig& config);

  /// Wind vector W(p, t) in m/s at ENU position p (m) and time t (s). With gust_std_m_s = 0
  /// this is exactly the mean.
  Vec3 at(const Vec3& p_m, double t_s) const;

  /// Gust part g(p, t) = W(p, t) − W̄ alone.
  Vec3 gust_at(const Vec3& p_m, double t_s) const;

  /// Standard deviations (σ_x, σ_y, σ_z) of the gust components, m/s.
  Vec3 gust_std_m_s() const { return gust_std_; }

  /// Bound on the gust's magnitude |g| used by the MPC's robust margin:
  /// n_sigma·√(σ_x² + σ_y² + σ_z²). For Gaussian gusts and n_sigma = 3, |g| exceeds it with
  /// probability ≈ 1e−4 at most (χ² tail; 1.2e−4 when σ_z = 0, 5e−6 when σ_z = σ_x).
  double gust_bound_m_s(double n_sigma = 3.0) const;

  /// Bound on how much the gust can change between a feed-forward reading at (p, t) and the
  /// wind met at (p + r, t + τ) with |r| = displacement_m, τ = lag_s:
  /// n_sigma·√(2·(1 − ρ(r, τ)))·√(σ_x² + σ_y² + σ_z²), ρ from eq. W2. It is 0 at zero lag and
  /// tends to √2·gust_bound_m_s(n_sigma) for lags ≫ T or displacements ≫ L, so the robust
  /// margin m_j can grow along the horizon (DESIGN §3).
  double gust_change_bound_m_s(double lag_s, double displacement_m, double n_sigma = 3.0) const;

  /// Correlation ρ(r, τ) = exp(−r²/(2L²) − τ²/(2T²)) of eq. W2 (dimensionless).
  double correlation(double lag_s, double displacement_m) const;

  const WindConfig& config() const { return config_; }

 private:
  WindConfig config_;
  Vec3 gust_std_;   // σ_c
  Vec3 amplitude_;  // A_c = σ_c √(2/N)
  // The modes, one array a parameter (the evaluation's loops run over the modes, two at a
  // time): wave vectors k_n (x, y, z), angular frequencies ω_n, and cos φ and sin φ of each
  // component's phase, precomputed so that cos(θ + φ) = cos θ cos φ − sin θ sin φ needs one
  // sin/cos pair a mode.
  std::vector<double> wave_x_, wave_y_, wave_z_, angular_frequency_;
  std::vector<double> cos_phase_[3], sin_phase_[3];
};

/// An anemometer: reading = truth + n, n ~ N(0, σ_n² I) with σ_n = measurement_noise_m_s,
/// independent between readings. Each sensor owns its noise stream, seeded from
/// derive_seed(derive_seed(seed, kWindSensorStream), sensor_id), so sensors of different UAVs
/// are independent and a run is reproducible.
class WindSensor {
 public:
  /// Validates `config` (field prefix `wind`).
  WindSensor(const WindConfig& config, std::uint64_t sensor_id);

  /// Reads the wind of `field` at (p, t). Does not allocate.
  Vec3 measure(const WindField& field, const Vec3& p_m, double t_s);

  /// Adds one draw of the noise to a true wind vector.
  Vec3 corrupt(const Vec3& true_wind_m_s);

  double noise_std_m_s() const { return noise_std_m_s_; }

  /// Bound on the reading error's magnitude |n|: n_sigma·√3·σ_n (same χ² argument as
  /// WindField::gust_bound_m_s). The robust margin adds it to the gust bound.
  double error_bound_m_s(double n_sigma = 3.0) const;

 private:
  double noise_std_m_s_;
  Rng rng_;
};

}  // namespace ridgeline::world
