// Rate and latency meters.
#include "server/stats.h"

#include <algorithm>
#include <ctime>
#include <vector>

namespace mocap {

namespace {
int64_t readClock(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}
}  // namespace

int64_t wallNowNs() { return readClock(CLOCK_REALTIME); }

void RateMeter::tick(int64_t now_ns) {
  std::lock_guard lock(mutex_);
  times_[count_ % kHistory] = now_ns;
  ++count_;
}

double RateMeter::rate(int64_t now_ns) const {
  std::lock_guard lock(mutex_);
  const uint64_t available = std::min<uint64_t>(count_, kHistory);
  int64_t oldest = 0;
  int64_t newest = 0;
  uint64_t in_window = 0;
  for (uint64_t i = 0; i < available; ++i) {
    const int64_t t = times_[(count_ - 1 - i) % kHistory];
    if (now_ns - t > kWindowNs) break;
    if (in_window == 0) newest = t;
    oldest = t;
    ++in_window;
  }
  if (in_window < 2 || newest <= oldest) return 0;
  return static_cast<double>(in_window - 1) * 1e9 / static_cast<double>(newest - oldest);
}

uint64_t RateMeter::count() const {
  std::lock_guard lock(mutex_);
  return count_;
}

int64_t RateMeter::sinceLast(int64_t now_ns) const {
  std::lock_guard lock(mutex_);
  if (count_ == 0) return -1;
  return now_ns - times_[(count_ - 1) % kHistory];
}

void LatencyWindow::add(int64_t latency_ns) {
  std::lock_guard lock(mutex_);
  samples_[count_ % kHistory] = latency_ns;
  ++count_;
}

LatencySummary LatencyWindow::summary() const {
  std::vector<int64_t> sorted;
  {
    std::lock_guard lock(mutex_);
    const uint64_t available = std::min<uint64_t>(count_, kHistory);
    sorted.assign(samples_.begin(), samples_.begin() + static_cast<std::ptrdiff_t>(available));
  }
  LatencySummary out;
  out.samples = sorted.size();
  if (sorted.empty()) return out;
  std::sort(sorted.begin(), sorted.end());
  const auto percentile = [&](double p) {
    const auto index = static_cast<std::size_t>(p * static_cast<double>(sorted.size() - 1) + 0.5);
    return static_cast<double>(sorted[index]) / 1e6;
  };
  out.p50_ms = percentile(0.50);
  out.p90_ms = percentile(0.90);
  out.p99_ms = percentile(0.99);
  out.max_ms = static_cast<double>(sorted.back()) / 1e6;
  return out;
}

}  // namespace mocap
