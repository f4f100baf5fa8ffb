// CPU time of the calling thread and of the process. On a shared machine the wall clock of a
// computation includes the time other processes held the core; its CPU time does not, so
// speed figures are reported in both.
#pragma once

#include <time.h>

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

}  // namespace ridgeline
