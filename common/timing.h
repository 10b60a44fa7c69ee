// Small timing helpers for per-stage timings in logs and responses.
#pragma once

#include <time.h>

#include <chrono>

namespace texfree {

using SteadyClock = std::chrono::steady_clock;

// Milliseconds elapsed since t0.
inline double MillisecondsSince(SteadyClock::time_point t0) {
  return std::chrono::duration<double, std::milli>(SteadyClock::now() - t0).count();
}

// CPU time of the calling thread in milliseconds: the work of a single-threaded task,
// whatever else the machine is doing (benchmarks on shared machines report it).
inline double ThreadCpuMilliseconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

}  // namespace texfree
