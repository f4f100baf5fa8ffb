// How fast this core runs now, reported beside every timed benchmark figure. The same code
// measures differently on two machines of one kind (issue 21's ninth round met one 1.3× slower
// than the round before) and on one machine while another tenant loads its host; a reading
// before and after the runs lets a reader tell a change of code from a change of machine.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "mission/statistics.hpp"

namespace ridgeline::benchmarks {

/// Dependent integer additions a nanosecond: the median of `samples` timings (steady clock) of
/// a chain of 2·10⁷ additions, each waiting for the one before. On cores that retire an add and
/// its loop's branch in one cycle (current x86-64 ones) this is the clock in GHz the core
/// actually ran at, turbo, throttling and stolen time included.
double dependent_adds_per_ns(int samples = 5);

/// The processor a /proc/cpuinfo text describes, from its first entry only: on x86 "model name
/// (vendor_id family F model M)", e.g. "Intel(R) Xeon(R) Processor (GenuineIntel family 6 model
/// 207)"; on arm64, which names no model, "implementer I part P variant V revision R" (the part
/// tells the core). Machines of one kind need not share a processor (issue 21 met an AMD EPYC
/// Zen 5 and an Intel Xeon, the same code 1.2–1.6× slower on the second), and a virtual machine
/// may hide the product name ("Intel(R) Xeon(R) Processor"): family and model still tell the
/// generation. Empty when the first entry names none of these.
std::string describe_processor(std::string_view cpuinfo);

/// describe_processor of this machine's /proc/cpuinfo; "unknown" where it cannot be read (not
/// Linux) or describes nothing.
std::string this_processor();

/// Readings of dependent_adds_per_ns before and after a benchmark's timed runs, and the
/// processor they ran on.
struct HostSpeed {
  double before = 0.0;
  double after = 0.0;
  std::string processor;  ///< this_processor()
  /// Before the timed runs: the processor and the first reading.
  void read_before();
  /// After them: the second reading.
  void read_after() { after = dependent_adds_per_ns(); }
  nlohmann::json to_json() const;
};

/// The times this thread was kept from running while it wanted to: a gap between two
/// back-to-back readings of the steady clock (a reading takes tens of nanoseconds) longer than
/// a threshold is an interruption — a guest interrupt, another task, or the host pausing the
/// virtual CPU, which no counter inside a guest need show (the development VMs report no steal
/// time, yet lose tens of microseconds every millisecond: README "Speed"). A timed step that
/// holds one is longer by its length whatever its code: at `per_ms` interruptions a millisecond
/// a step of t µs holds one with probability about per_ms·t/1000, and once that share passes
/// 1 % the step's p99 is about its median plus an interruption.
struct HostInterruptions {
  double probed_ms = 0.0;          ///< how long the clock was read
  int count = 0;                   ///< gaps longer than the threshold
  double per_ms = 0.0;             ///< count / probed_ms
  mission::Percentiles length_us;  ///< of the gaps
  double lost_fraction = 0.0;      ///< the gaps' sum / the probe's time
  nlohmann::json to_json() const;
};

/// The probe the benchmarks run before their timed work: long enough to see a few hundred
/// pauses of a host that pauses every millisecond, short beside the work.
inline constexpr double kInterruptionProbeMs = 250.0;
inline constexpr double kInterruptionThresholdUs = 2.0;

/// The summary of the gaps (µs, each above the threshold) found in `probed_us` of reading.
HostInterruptions summarize_interruptions(std::vector<double> gaps_us, double probed_us);

/// Reads the steady clock back to back for `duration_ms` on the calling thread and summarizes
/// the gaps longer than `threshold_us`. Throws InputError unless both are finite and > 0.
HostInterruptions probe_interruptions(double duration_ms = kInterruptionProbeMs,
                                      double threshold_us = kInterruptionThresholdUs);

/// The probe's scan over any clock (µs readings; tests pass a scripted one). It ends at the
/// first reading `duration_us` after the first, so the clock must advance. Throws InputError
/// unless the duration and threshold are finite and > 0.
HostInterruptions scan_for_interruptions(double (*now_us)(), double duration_us,
                                         double threshold_us);

}  // namespace ridgeline::benchmarks
