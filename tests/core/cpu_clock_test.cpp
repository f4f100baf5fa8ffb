#include "core/cpu_clock.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace ridgeline {
namespace {

// Burns the calling thread's CPU until it has used `cpu_s` more.
void spin_for_cpu(double cpu_s) {
  const double until = thread_cpu_time_s() + cpu_s;
  volatile double sink = 0.0;
  while (thread_cpu_time_s() < until) sink = sink + 1.0;
}

TEST(CpuBudget, AThreadThatWaitsSpendsNothingAndOneThatWorksSpendsItsCpuTime) {
  CpuBudget budget(1.0);
  {
    CpuMeter meter(budget);
    // Waiting (what a loaded machine makes a thread do) is not CPU time.
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    meter.charge();
    EXPECT_LT(budget.spent_s(), 0.1);
    spin_for_cpu(0.05);
    EXPECT_LE(meter.remaining_s(), 1.0 - 0.05);
  }
  EXPECT_GE(budget.spent_s(), 0.05);
}

TEST(CpuBudget, EveryThreadChargesTheSharedBudget) {
  CpuBudget budget(0.2);
  auto work = [&] {
    CpuMeter meter(budget);
    spin_for_cpu(0.06);
  };  // the meter charges when it goes
  std::thread a(work), b(work);
  a.join();
  b.join();
  EXPECT_GE(budget.spent_s(), 0.12);
  EXPECT_LE(budget.remaining_s(), 0.2 - 0.12);
}

}  // namespace
}  // namespace ridgeline
