// CPU time of the calling thread and of the process. On a shared machine the wall clock of a
// computation includes the time other processes held the core; its CPU time does not, so
// speed figures are reported in both.
#pragma once

#include <time.h>

#include <atomic>
#include <cmath>

namespace ridgeline {

/// CPU seconds the calling thread has used (CLOCK_THREAD_CPUTIME_ID).
inline double thread_cpu_time_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

/// CPU seconds all threads of the process have used (CLOCK_PROCESS_CPUTIME_ID).
inline double process_cpu_time_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

/// A CPU-time budget shared by the threads that work on one computation. Each thread charges
/// its own CPU time (thread_cpu_time_s, through a CpuMeter), so the budget neither runs out
/// sooner on a loaded machine (the wall clock would) nor when other threads of the process work
/// on something else (the process CPU time would): a computation that finishes within its
/// budget does the same work, and gives the same result, whatever the load.
class CpuBudget {
 public:
  explicit CpuBudget(double budget_s) : budget_s_(budget_s) {}
  CpuBudget(const CpuBudget&) = delete;
  CpuBudget& operator=(const CpuBudget&) = delete;

  double budget_s() const { return budget_s_; }
  /// CPU seconds charged so far, by every thread.
  double spent_s() const { return static_cast<double>(spent_ns_.load()) * 1e-9; }
  /// The budget less what has been charged (what other threads use but have not charged yet
  /// is not counted: at most their current piece of work over the budget).
  double remaining_s() const { return budget_s_ - spent_s(); }
  void charge(double cpu_s) { spent_ns_ += std::llround(cpu_s * 1e9); }

 private:
  double budget_s_;
  std::atomic<long long> spent_ns_{0};
};

/// One thread's meter on a CpuBudget: charges the CPU time that thread used since its last
/// charge (or since the meter was made). Use it from the thread that made it only.
class CpuMeter {
 public:
  explicit CpuMeter(CpuBudget& budget) : budget_(budget), mark_s_(thread_cpu_time_s()) {}
  CpuMeter(const CpuMeter&) = delete;
  CpuMeter& operator=(const CpuMeter&) = delete;
  ~CpuMeter() { charge(); }

  void charge() {
    const double now_s = thread_cpu_time_s();
    budget_.charge(now_s - mark_s_);
    mark_s_ = now_s;
  }
  /// Charges, then the budget's remaining CPU seconds.
  double remaining_s() {
    charge();
    return budget_.remaining_s();
  }

 private:
  CpuBudget& budget_;
  double mark_s_;
};

}  // namespace ridgeline
