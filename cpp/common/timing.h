// Wall-clock timing of the tools' stages (the `timings_s` of their JSON outputs).
#pragma once

#include <chrono>

namespace mound {

using Clock = std::chrono::steady_clock;

// Seconds since `t0`.
inline double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace mound
