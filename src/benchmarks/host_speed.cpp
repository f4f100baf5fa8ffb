#include "benchmarks/host_speed.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include "core/error.hpp"

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

HostInterruptions summarize_interruptions(std::vector<double> gaps_us, double probed_us) {
  HostInterruptions h;
  h.probed_ms = probed_us / 1000.0;
  h.count = static_cast<int>(gaps_us.size());
  double lost = 0.0;
  for (const double g : gaps_us) lost += g;
  if (probed_us > 0.0) {
    h.per_ms = h.count / h.probed_ms;
    h.lost_fraction = lost / probed_us;
  }
  h.length_us = mission::percentiles(std::move(gaps_us));
  return h;
}

HostInterruptions scan_for_interruptions(double (*now_us)(), double duration_us,
                                         double threshold_us) {
  if (!(std::isfinite(duration_us) && duration_us > 0.0)) {
    throw InputError("duration", "must be finite and above 0");
  }
  if (!(std::isfinite(threshold_us) && threshold_us > 0.0)) {
    throw InputError("threshold", "must be finite and above 0");
  }
  // Room for every possible gap (the gaps before the last reading sum to less than the
  // duration, so there are at most duration / threshold + 1): a reallocation inside the scan
  // would read as one. Beyond a million gaps (a threshold far below the clock's own cost) the
  // vector grows instead.
  constexpr double kMaxReserved = 1e6;
  std::vector<double> gaps_us;
  gaps_us.reserve(static_cast<std::size_t>(std::min(duration_us / threshold_us, kMaxReserved)) + 1);
  const double start = now_us();
  double previous = start;
  for (;;) {
    const double now = now_us();
    if (now - previous > threshold_us) gaps_us.push_back(now - previous);
    previous = now;
    if (now - start >= duration_us) break;
  }
  return summarize_interruptions(std::move(gaps_us), previous - start);
}

HostInterruptions probe_interruptions(double duration_ms, double threshold_us) {
  // Microseconds from a fixed origin: a double holds them to well below a nanosecond for days.
  const auto steady_us = []() {
    return std::chrono::duration<double, std::micro>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  };
  return scan_for_interruptions(+steady_us, duration_ms * 1000.0, threshold_us);
}

nlohmann::json HostInterruptions::to_json() const {
  return {{"probed_ms", probed_ms},
          {"count", count},
          {"per_ms", per_ms},
          {"length_us", mission::to_json(length_us)},
          {"lost_fraction", lost_fraction}};
}

std::string describe_processor(std::string_view cpuinfo) {
  // "key<tabs>: value" lines, one entry a processor, entries separated by a blank line; only
  // the first entry is read, so that no field comes from another processor.
  struct Field {
    std::string_view key, label;  // the label names the value in the description
    std::string value;
  };
  std::string model_name;
  Field ids[] = {{"vendor_id", "", {}},
                 {"cpu family", "family ", {}},
                 {"model", "model ", {}},
                 {"CPU implementer", "implementer ", {}},
                 {"CPU part", "part ", {}},
                 {"CPU variant", "variant ", {}},
                 {"CPU revision", "revision ", {}}};
  const auto trim = [](std::string_view s) {
    const std::size_t first = s.find_first_not_of(" \t\r");
    if (first == std::string_view::npos) return std::string_view{};
    return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
  };
  bool in_entry = false;
  while (!cpuinfo.empty()) {
    const std::size_t end = cpuinfo.find('\n');
    const std::string_view line = cpuinfo.substr(0, end);
    cpuinfo = end == std::string_view::npos ? std::string_view{} : cpuinfo.substr(end + 1);
    if (trim(line).empty()) {
      if (in_entry) break;  // the end of the first entry
      continue;
    }
    in_entry = true;
    const std::size_t colon = line.find(':');
    if (colon == std::string_view::npos) continue;
    const std::string_view key = trim(line.substr(0, colon)), value = trim(line.substr(colon + 1));
    if (key == "model name" && model_name.empty()) model_name = value;
    for (Field& f : ids) {
      if (key == f.key && f.value.empty()) f.value = value;
    }
  }
  // x86 names a model, vendor, family and model; arm64 only an implementer, part, variant and
  // revision (the part tells the core, e.g. 0xd42 a Cortex-A78AE).
  std::string described;
  for (const Field& f : ids) {
    if (f.value.empty()) continue;
    if (!described.empty()) described.append(" ");
    described.append(f.label).append(f.value);
  }
  if (model_name.empty()) return described;
  if (described.empty()) return model_name;
  return model_name.append(" (").append(described).append(")");
}

std::string this_processor() {
  std::ifstream file("/proc/cpuinfo");
  std::ostringstream text;
  if (file) text << file.rdbuf();
  std::string description = describe_processor(text.str());
  return description.empty() ? "unknown" : description;
}

void HostSpeed::read_before() {
  processor = this_processor();
  before = dependent_adds_per_ns();
}

nlohmann::json HostSpeed::to_json() const {
  return {{"dependent_adds_per_ns_before", before},
          {"dependent_adds_per_ns_after", after},
          {"processor", processor}};
}

}  // namespace ridgeline::benchmarks
