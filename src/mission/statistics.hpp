// Small statistics for reports: percentiles of a sample and Wilson score intervals.
#pragma once

#include <nlohmann/json.hpp>
#include <vector>

namespace ridgeline::mission {

struct Percentiles {
  double median = 0.0, p90 = 0.0, p99 = 0.0, max = 0.0;
};

/// Percentiles of a sample (sorted copy; nearest rank). All zero for an empty sample.
Percentiles percentiles(std::vector<double> values);
nlohmann::json to_json(const Percentiles& p);

/// Wilson score interval of a proportion successes/trials at z (1.96: 95 %). [0, 1] for 0 trials.
struct Interval {
  double low = 0.0, high = 1.0;
};
Interval wilson_interval(long long successes, long long trials, double z = 1.96);

}  // namespace ridgeline::mission
