// How fast this core runs now, reported beside every timed benchmark figure. The same code
// measures differently on two machines of one kind (issue 21's ninth round met one 1.3× slower
// than the round before) and on one machine while another tenant loads its host; a reading
// before and after the runs lets a reader tell a change of code from a change of machine.
#pragma once

#include <nlohmann/json.hpp>

namespace ridgeline::benchmarks {

/// Dependent integer additions a nanosecond: the median of `samples` timings (steady clock) of
/// a chain of 2·10⁷ additions, each waiting for the one before. On cores that retire an add and
/// its loop's branch in one cycle (current x86-64 ones) this is the clock in GHz the core
/// actually ran at, turbo, throttling and stolen time included.
double dependent_adds_per_ns(int samples = 5);

/// Readings of dependent_adds_per_ns before and after a benchmark's timed runs.
struct HostSpeed {
  double before = 0.0;
  double after = 0.0;
  nlohmann::json to_json() const;
};

}  // namespace ridgeline::benchmarks
