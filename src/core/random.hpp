// Seeded random numbers that give the same sequence on every platform.
//
// The C++ standard fixes std::mt19937_64's output but not the algorithms of
// std::normal_distribution and friends, so those are implemented here: a run is reproducible
// from its scenario file and seed wherever it is built (STYLE.md, determinism).
#pragma once

#include <cstdint>
#include <random>

namespace ridgeline {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}

  /// Uniform in [0, 1).
  double uniform() {
    // 53 random mantissa bits.
    return static_cast<double>(engine_() >> 11) * 0x1.0p-53;
  }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal N(0, 1) by the Box-Muller transform.
  double normal();
  /// Normal N(mean, stddev^2).
  double normal(double mean, double stddev) { return mean + stddev * normal(); }
  /// Raw 64 random bits (e.g. to seed a child generator).
  std::uint64_t next_u64() { return engine_(); }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// Derives an independent seed for a named sub-stream (e.g. "wind", "threat-sensor/2").
std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t stream);

}  // namespace ridgeline
