// Helpers shared by the frame synchronizer tests: a 25 Hz rig's time slots, frames, configs, a
// hand-moved clock, and the invariants every run must keep.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "drivers/sync/frame_synchronizer.h"

namespace mocap::sync_test {

inline constexpr int64_t kMs = 1'000'000;
inline constexpr int64_t kPeriod = 40 * kMs;           // 25 Hz
inline constexpr int64_t kTolerance = kPeriod / 3;     // the default
inline constexpr int64_t kDeadline = 2 * kPeriod;      // the default
inline constexpr int64_t kOrigin = 5'000'000'000'000;  // a plausible CLOCK_MONOTONIC reading

inline int64_t slot(int k) { return kOrigin + k * kPeriod; }

inline Frame makeFrame(int camera, uint64_t sequence, int64_t timestamp_ns) {
  Frame frame;
  frame.camera = camera;
  frame.sequence = sequence;
  frame.timestamp_ns = timestamp_ns;
  return frame;
}

// A clock the test moves by hand; outlives the synchronizer that reads it.
struct ManualClock {
  std::atomic<int64_t> now{kOrigin};
  std::function<int64_t()> source() {
    return [this] { return now.load(); };
  }
};

inline SyncConfig baseConfig(int cameras, SyncMode mode) {
  SyncConfig config;
  config.camera_count = cameras;
  config.frame_period = std::chrono::nanoseconds(kPeriod);
  config.mode = mode;
  return config;
}

inline std::unique_ptr<FrameSynchronizer> makeSync(SyncConfig config) {
  auto created = FrameSynchronizer::create(std::move(config));
  if (!created.ok()) throw std::runtime_error(created.error());
  return std::move(created.value());
}

inline std::vector<FrameSet> drain(FrameSynchronizer& sync) {
  std::vector<FrameSet> sets;
  while (auto set = sync.pop(std::chrono::nanoseconds::zero())) sets.push_back(std::move(*set));
  return sets;
}

inline void pushAndCollect(FrameSynchronizer& sync, Frame frame, std::vector<FrameSet>& sets) {
  sync.push(std::move(frame));
  for (auto& set : drain(sync)) sets.push_back(std::move(set));
}

// Every frame the synchronizer received is in a set handed out, dropped with a cause, or held.
inline void expectCountsAddUp(const SyncStats& stats) {
  EXPECT_EQ(stats.sets_emitted, stats.sets_complete + stats.sets_incomplete);
  std::size_t buffered = 0;
  for (std::size_t c = 0; c < stats.cameras.size(); ++c) {
    const auto& camera = stats.cameras[c];
    EXPECT_EQ(camera.frames_received,
              camera.frames_emitted + camera.droppedTotal() + camera.frames_buffered)
        << "camera " << c;
    EXPECT_EQ(camera.frames_emitted + camera.sets_missed, stats.sets_emitted) << "camera " << c;
    buffered += camera.frames_buffered;
  }
  EXPECT_EQ(buffered, stats.frames_buffered);
}

// Sets in time order, each frame used at most once, members within the tolerance of each other.
inline void expectWellFormed(const std::vector<FrameSet>& sets,
                             const std::vector<int64_t>& offsets_ns = {}) {
  std::set<std::pair<std::size_t, uint64_t>> used;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const FrameSet& set = sets[i];
    if (i > 0) {
      EXPECT_GT(set.timestamp_ns, sets[i - 1].timestamp_ns) << "set " << i;
      EXPECT_GT(set.sequence, sets[i - 1].sequence) << "set " << i;
    }
    ASSERT_GT(set.presentCount(), 0) << "set " << i;
    int64_t earliest = INT64_MAX;
    int64_t latest = INT64_MIN;
    for (std::size_t c = 0; c < set.frames.size(); ++c) {
      if (!set.frames[c]) continue;
      EXPECT_EQ(set.frames[c]->camera, static_cast<int>(c));
      EXPECT_TRUE(used.emplace(c, set.frames[c]->sequence).second)
          << "camera " << c << " frame " << set.frames[c]->sequence << " used twice";
      const int64_t corrected =
          set.frames[c]->timestamp_ns + (offsets_ns.empty() ? 0 : offsets_ns[c]);
      earliest = std::min(earliest, corrected);
      latest = std::max(latest, corrected);
    }
    EXPECT_LE(latest - earliest, kTolerance) << "set " << i;
    EXPECT_GE(set.timestamp_ns, earliest);
    EXPECT_LE(set.timestamp_ns, latest);
  }
}

}  // namespace mocap::sync_test
