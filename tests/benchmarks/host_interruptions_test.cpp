// The interruption probe reported beside `bench mpc`'s tail: its summary of given gaps, its
// scan over a scripted clock, and a probe of the real one; and the processor a benchmark names.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <limits>

#include "benchmarks/host_speed.hpp"
#include "core/error.hpp"

namespace ridgeline::benchmarks {
namespace {

// A host that pauses the thread 36 µs every millisecond, plus one 100 µs pause, over 10 ms.
TEST(HostInterruptions, TheSummaryCountsRatesAndLengthsOfTheGapsGiven) {
  std::vector<double> gaps(10, 36.0);
  gaps.push_back(100.0);
  const HostInterruptions h = summarize_interruptions(gaps, 10'000.0);
  EXPECT_DOUBLE_EQ(h.probed_ms, 10.0);
  EXPECT_EQ(h.count, 11);
  EXPECT_DOUBLE_EQ(h.per_ms, 1.1);
  EXPECT_DOUBLE_EQ(h.length_us.median, 36.0);
  EXPECT_DOUBLE_EQ(h.length_us.max, 100.0);
  EXPECT_DOUBLE_EQ(h.lost_fraction, 460.0 / 10'000.0);
  const nlohmann::json j = h.to_json();
  EXPECT_EQ(j["count"], 11);
  EXPECT_DOUBLE_EQ(j["length_us"]["max"].get<double>(), 100.0);
  EXPECT_DOUBLE_EQ(j["per_ms"].get<double>(), 1.1);

  const HostInterruptions none = summarize_interruptions({}, 0.0);
  EXPECT_EQ(none.count, 0);
  EXPECT_EQ(none.per_ms, 0.0);
  EXPECT_EQ(none.lost_fraction, 0.0);
}

// A scripted clock: 30 ns a reading, with a 40 µs pause every 1000 readings and one of 3 µs,
// over a 70 µs scan at a 2 µs threshold.
int fake_reads = 0;
double fake_now_us() {
  const int n = fake_reads++;
  double t = 0.03 * n + 40.0 * (n / 1000);
  if (n >= 500) t += 3.0;
  return t;
}

TEST(HostInterruptions, TheScanFindsEachPauseLongerThanTheThresholdAndStopsAtItsDuration) {
  fake_reads = 0;
  const HostInterruptions h = scan_for_interruptions(fake_now_us, 70.0, 2.0);
  // Reading 500 jumps 3 µs, reading 1000 40 µs, which takes the clock past 70 µs: the scan
  // stops there.
  EXPECT_EQ(h.count, 2);
  EXPECT_NEAR(h.length_us.max, 40.03, 1e-9);
  EXPECT_NEAR(h.length_us.median, 3.03, 1e-9);
  EXPECT_NEAR(h.probed_ms * 1000.0, 0.03 * 1000 + 43.0, 1e-9);
  EXPECT_EQ(fake_reads, 1001);
  // Above the 40 µs pause's length nothing is an interruption.
  fake_reads = 0;
  EXPECT_EQ(scan_for_interruptions(fake_now_us, 70.0, 41.0).count, 0);
}

TEST(HostInterruptions, ADurationOrThresholdThatIsNotFiniteAndPositiveIsAnError) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const double bad : {0.0, -1.0, nan, inf}) {
    fake_reads = 0;
    EXPECT_THROW(scan_for_interruptions(fake_now_us, bad, 2.0), InputError) << bad;
    EXPECT_THROW(scan_for_interruptions(fake_now_us, 70.0, bad), InputError) << bad;
    EXPECT_THROW(probe_interruptions(bad, 2.0), InputError) << bad;
    EXPECT_EQ(fake_reads, 0) << "checked before the clock is read";
  }
  try {
    probe_interruptions(10.0, nan);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "threshold");
  }
}

// The probe on the real clock: it lasts as long as asked and its gaps fit in it.
TEST(HostInterruptions, AProbeLastsItsDurationAndItsGapsFitInIt) {
  const auto start = std::chrono::steady_clock::now();
  const HostInterruptions h = probe_interruptions(20.0, 2.0);
  const double elapsed_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(h.probed_ms, 20.0);
  EXPECT_LE(h.probed_ms, elapsed_ms);
  // On a loaded machine the whole probe can be one gap (the thread preempted past its end).
  EXPECT_GE(h.lost_fraction, 0.0);
  EXPECT_LE(h.lost_fraction, 1.0);
  EXPECT_NEAR(h.per_ms, h.count / h.probed_ms, 1e-9);
  if (h.count > 0) {
    EXPECT_GT(h.length_us.median, 2.0);  // only gaps above the threshold are counted
    EXPECT_LE(h.length_us.max, h.probed_ms * 1000.0);
  }
}

// /proc/cpuinfo's first entry names the processor: its model name, then vendor, family and
// model (a VM's generic "Intel(R) Xeon(R) Processor" is told apart by them). Only the first
// entry is read; other keys ("model" inside "model name"), spacing and CRLF do not confuse it.
TEST(DescribeProcessor, NamesTheFirstEntrysModelWithItsVendorFamilyAndModel) {
  const char* xeon =
      "processor\t: 0\nvendor_id\t: GenuineIntel\ncpu family\t: 6\nmodel\t\t: 207\n"
      "model name\t: Intel(R) Xeon(R) Processor\nstepping\t: 2\n\n"
      "processor\t: 1\nvendor_id\t: OtherVendor\ncpu family\t: 9\nmodel\t\t: 1\n"
      "model name\t: Something Else\n";
  EXPECT_EQ(describe_processor(xeon),
            "Intel(R) Xeon(R) Processor (GenuineIntel family 6 model 207)");
  // The model name before the ids, CRLF line ends, and a value with a colon.
  const char* epyc =
      "model name : AMD EPYC 9R45 96-Core Processor: rev B\r\nvendor_id : AuthenticAMD\r\n"
      "cpu family : 26\r\nmodel : 2\r\n";
  EXPECT_EQ(describe_processor(epyc),
            "AMD EPYC 9R45 96-Core Processor: rev B (AuthenticAMD family 26 model 2)");
  // Blank lines before the first entry are skipped.
  EXPECT_EQ(describe_processor("\n\r\nmodel name : X\n"), "X");
  // No model name: nothing to report (this_processor then says "unknown").
  EXPECT_EQ(describe_processor(""), "");
  EXPECT_EQ(describe_processor("processor : 0\nmodel name :   \nflags : fpu\n"), "");
}

// Nothing of the second entry completes the first: a first entry without a model name or
// vendor stays without them, though the next one has them.
TEST(DescribeProcessor, ReadsTheFirstEntryOnly) {
  EXPECT_EQ(describe_processor("processor : 0\ncpu family : 6\n\nprocessor : 1\n"
                               "model name : Second\nvendor_id : B\n"),
            "family 6");
  EXPECT_EQ(describe_processor("model name : First\n\nvendor_id : B\ncpu family : 9\n"), "First");
}

// arm64 names no model: its implementer, part (the core: 0xd42 is a Cortex-A78AE, a Jetson
// Orin's), variant and revision describe it.
TEST(DescribeProcessor, AnArm64EntryIsDescribedByImplementerAndPart) {
  const char* orin =
      "processor\t: 0\nBogoMIPS\t: 62.50\nFeatures\t: fp asimd evtstrm\n"
      "CPU implementer\t: 0x41\nCPU architecture: 8\nCPU variant\t: 0x0\n"
      "CPU part\t: 0xd42\nCPU revision\t: 1\n\nprocessor\t: 1\nCPU part\t: 0xd41\n";
  EXPECT_EQ(describe_processor(orin), "implementer 0x41 part 0xd42 variant 0x0 revision 1");
}

// On this machine: the model name of /proc/cpuinfo's first entry, read here line by line.
TEST(DescribeProcessor, ThisMachineIsNamedAsItsCpuinfoSays) {
  const std::string name = this_processor();
  std::ifstream file("/proc/cpuinfo");
  if (!file) GTEST_SKIP() << "no /proc/cpuinfo here";
  std::string line, model_name;
  bool arm = false;
  while (std::getline(file, line) && !line.empty()) {
    if (line.rfind("model name", 0) == 0 && model_name.empty()) {
      model_name = line.substr(line.find(':') + 2);
    }
    arm = arm || line.rfind("CPU implementer", 0) == 0;
  }
  if (model_name.empty() && !arm) {
    EXPECT_EQ(name, "unknown");
  } else {
    EXPECT_NE(name, "unknown");
    EXPECT_EQ(name.rfind(model_name, 0), 0u) << name;  // it starts with the model name
  }
}

}  // namespace
}  // namespace ridgeline::benchmarks
