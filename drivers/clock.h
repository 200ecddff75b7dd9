// The clock frame timestamps live in: CLOCK_MONOTONIC, read as nanoseconds, for the drivers and
// everything built on them.
#pragma once

#include <time.h>

#include <cstdint>

namespace mocap {

inline int64_t monotonicNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace mocap
