// Small timing helpers for per-stage timings in logs and responses.
#pragma once

#include <chrono>

namespace texfree {

using SteadyClock = std::chrono::steady_clock;

// Milliseconds elapsed since t0.
inline double MillisecondsSince(SteadyClock::time_point t0) {
  return std::chrono::duration<double, std::milli>(SteadyClock::now() - t0).count();
}

}  // namespace texfree
