// Small thread-safe meters behind GetStatus: event rates over a sliding window and latency
// percentiles over the most recent samples. Cheap enough to update once per frame.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <mutex>

#include "drivers/clock.h"

namespace mocap {

int64_t wallNowNs();

// Events per second over the last `kWindowNs`, from the times of the most recent events.
class RateMeter {
 public:
  void tick(int64_t now_ns);
  double rate(int64_t now_ns) const;
  uint64_t count() const;
  // Nanoseconds since the last event; -1 if none yet.
  int64_t sinceLast(int64_t now_ns) const;

  static constexpr int64_t kWindowNs = 2'000'000'000;

 private:
  static constexpr std::size_t kHistory = 128;
  mutable std::mutex mutex_;
  std::array<int64_t, kHistory> times_{};
  uint64_t count_ = 0;
};

struct LatencySummary {
  double p50_ms = 0, p90_ms = 0, p99_ms = 0, max_ms = 0;
  std::size_t samples = 0;
};

// Percentiles over the last kHistory samples.
class LatencyWindow {
 public:
  void add(int64_t latency_ns);
  LatencySummary summary() const;

  static constexpr std::size_t kHistory = 1024;

 private:
  mutable std::mutex mutex_;
  std::array<int64_t, kHistory> samples_{};
  uint64_t count_ = 0;
};

}  // namespace mocap
