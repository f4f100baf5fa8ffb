#include "benchmarks/host_speed.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <vector>

namespace ridgeline::benchmarks {

double dependent_adds_per_ns(int samples) {
  constexpr std::int64_t kAdds = 20'000'000;
  std::vector<double> rates;
  std::uint64_t sink = 0;
  for (int s = 0; s < std::max(samples, 1); ++s) {
    std::uint64_t x = sink;
    const auto start = std::chrono::steady_clock::now();
    for (std::int64_t i = 0; i < kAdds; ++i) {
      x += 1;
      // An empty statement that "changes" x: the compiler can neither fold the chain into one
      // addition nor vectorize it, so each addition waits for the one before.
      asm volatile("" : "+r"(x));
    }
    const std::chrono::duration<double, std::nano> elapsed =
        std::chrono::steady_clock::now() - start;
    sink = x;
    rates.push_back(static_cast<double>(kAdds) / elapsed.count());
  }
  std::nth_element(rates.begin(), rates.begin() + rates.size() / 2, rates.end());
  return rates[rates.size() / 2];
}

nlohmann::json HostSpeed::to_json() const {
  return {{"dependent_adds_per_ns_before", before}, {"dependent_adds_per_ns_after", after}};
}

}  // namespace ridgeline::benchmarks
