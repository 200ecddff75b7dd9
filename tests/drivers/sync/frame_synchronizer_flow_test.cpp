// Tests of the frame synchronizer's flow: the live flow limiter against lossless replay, bounded
// memory, shared pixels, closing, and concurrent producers. Time is driven by an injected clock or
// advance(), never by sleeping.
#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "drivers/sync/frame_synchronizer.h"
#include "tests/drivers/sync/frame_synchronizer_test_support.h"

namespace mocap {
namespace {

using namespace std::chrono_literals;
using namespace sync_test;

// Pushes `periods` aligned periods of `cameras` cameras, never consuming.
void pushPeriods(FrameSynchronizer& sync, int cameras, int periods) {
  for (int k = 0; k < periods; ++k) {
    for (int c = 0; c < cameras; ++c) sync.push(makeFrame(c, k, slot(k)));
  }
}

TEST(FrameSynchronizer, LiveModeKeepsOnlyTheNewestUnconsumedSet) {
  ManualClock clock;
  SyncConfig config = baseConfig(3, SyncMode::kLive);
  config.clock = clock.source();
  auto sync = makeSync(config);
  pushPeriods(*sync, 3, 20);
  const std::vector<FrameSet> sets = drain(*sync);
  ASSERT_EQ(sets.size(), 1u);
  EXPECT_EQ(sets[0].sequence, 19u);
  EXPECT_TRUE(sets[0].complete());
  const SyncStats stats = sync->stats();
  EXPECT_EQ(stats.sets_superseded, 19u);
  for (const auto& camera : stats.cameras) EXPECT_EQ(camera.droppedBy(DropCause::kSuperseded), 19u);
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, ReplayModeLosesNothingAndHoldsBackTheProducer) {
  SyncConfig config = baseConfig(3, SyncMode::kReplay);
  auto sync = makeSync(config);
  constexpr int kPeriods = 200;  // far more than the buffers hold: the producer must wait
  std::thread producer([&] { pushPeriods(*sync, 3, kPeriods); });
  std::vector<FrameSet> sets;
  while (sets.size() < kPeriods) {
    auto set = sync->pop(10s);
    if (!set) break;
    sets.push_back(std::move(*set));
  }
  producer.join();
  ASSERT_EQ(sets.size(), static_cast<std::size_t>(kPeriods));
  for (int k = 0; k < kPeriods; ++k) {
    EXPECT_TRUE(sets[k].complete());
    EXPECT_EQ(sets[k].sequence, static_cast<uint64_t>(k));
  }
  const SyncStats stats = sync->stats();
  for (const auto& camera : stats.cameras) EXPECT_EQ(camera.droppedTotal(), 0u);
  EXPECT_LE(stats.peak_frames_buffered, 3 * (config.frames_per_camera + config.replay_queue_sets));
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, ReplayAdvanceLetsAGapInOneCameraPassWithoutLoss) {
  auto sync = makeSync(baseConfig(2, SyncMode::kReplay));
  std::vector<FrameSet> sets;
  // Camera 1's recording has a 12-period gap, longer than a camera buffer: without advance(),
  // camera 0's producer would wait for it forever.
  for (int k = 0; k < 30; ++k) {
    sync->advance(slot(k));
    pushAndCollect(*sync, makeFrame(0, k, slot(k)), sets);
    if (k < 5 || k >= 17) pushAndCollect(*sync, makeFrame(1, k, slot(k)), sets);
  }
  sync->close();
  for (auto& set : drain(*sync)) sets.push_back(std::move(set));
  ASSERT_EQ(sets.size(), 30u);
  for (int k = 0; k < 30; ++k) {
    EXPECT_EQ(sets[k].frames[0]->sequence, static_cast<uint64_t>(k));
    EXPECT_EQ(sets[k].complete(), k < 5 || k >= 17) << "set " << k;
  }
  const SyncStats stats = sync->stats();
  for (const auto& camera : stats.cameras) EXPECT_EQ(camera.droppedTotal(), 0u);
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, MemoryStaysBoundedUnderAFlood) {
  ManualClock clock;  // frozen: no deadline ever passes
  SyncConfig config = baseConfig(2, SyncMode::kLive);
  config.clock = clock.source();
  auto sync = makeSync(config);
  constexpr int kFlood = 10'000;
  for (int k = 0; k < kFlood; ++k) sync->push(makeFrame(0, k, slot(k)));  // camera 1 silent
  SyncStats stats = sync->stats();
  EXPECT_LE(stats.peak_frames_buffered, config.frames_per_camera);
  EXPECT_EQ(stats.cameras[0].droppedBy(DropCause::kOverflow), kFlood - config.frames_per_camera);
  expectCountsAddUp(stats);

  auto both = makeSync(config);  // both cameras flood and nobody consumes
  pushPeriods(*both, 2, kFlood);
  stats = both->stats();
  EXPECT_LE(stats.peak_frames_buffered, 2 * config.frames_per_camera + 2);
  EXPECT_EQ(stats.sets_superseded, static_cast<uint64_t>(kFlood - 1));
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, SetsSharePixelsWithTheDriversFrames) {
  auto sync = makeSync(baseConfig(2, SyncMode::kReplay));
  const cv::Mat image(580, 780, CV_8UC1, cv::Scalar(7));
  for (int c = 0; c < 2; ++c) {
    Frame frame = makeFrame(c, 0, slot(0));
    frame.image = image;
    sync->push(std::move(frame));
  }
  auto set = sync->pop(0ns);
  ASSERT_TRUE(set.has_value());
  EXPECT_EQ(set->frames[0]->image.data, image.data);
  EXPECT_EQ(set->frames[1]->image.data, image.data);
}

TEST(FrameSynchronizer, PushesAfterCloseAreCountedAndPopReturnsEmpty) {
  auto sync = makeSync(baseConfig(2, SyncMode::kLive));
  sync->close();
  sync->push(makeFrame(0, 0, slot(0)));
  sync->push(makeFrame(7, 0, slot(0)));  // no such camera
  EXPECT_FALSE(sync->pop(1s).has_value());
  const SyncStats stats = sync->stats();
  EXPECT_EQ(stats.cameras[0].droppedBy(DropCause::kClosed), 1u);
  EXPECT_EQ(stats.frames_from_unknown_camera, 1u);
  expectCountsAddUp(stats);
}

// Several driver threads push while a consumer pops; `threads` split the cameras between them.
struct ConcurrentRun {
  std::vector<FrameSet> sets;
  SyncStats stats;
};

ConcurrentRun runConcurrently(SyncMode mode, int cameras, int threads, int periods) {
  std::atomic<int64_t> newest_exposure{kOrigin};  // the live clock follows the fastest producer
  SyncConfig config = baseConfig(cameras, mode);
  config.clock = [&] { return newest_exposure.load(); };
  auto sync = makeSync(config);

  ConcurrentRun run;
  std::atomic<bool> closed{false};
  std::thread consumer([&] {
    for (;;) {
      auto set = sync->pop(5ms);
      if (set) {
        run.sets.push_back(std::move(*set));
      } else if (closed) {
        return;
      }
    }
  });
  std::vector<std::thread> producers;
  for (int t = 0; t < threads; ++t) {
    producers.emplace_back([&, t] {
      for (int k = 0; k < periods; ++k) {
        for (int c = t; c < cameras; c += threads) {
          int64_t seen = newest_exposure.load();
          while (seen < slot(k) && !newest_exposure.compare_exchange_weak(seen, slot(k))) {
          }
          sync->push(makeFrame(c, k, slot(k)));
        }
      }
    });
  }
  for (auto& producer : producers) producer.join();
  sync->close();
  closed = true;
  consumer.join();
  run.stats = sync->stats();
  return run;
}

class ConcurrentPushes : public testing::TestWithParam<int> {};

TEST_P(ConcurrentPushes, LiveCountsAddUpAndNoFrameIsUsedTwice) {
  constexpr int kCameras = 4;
  constexpr int kPeriods = 3000;
  const ConcurrentRun run = runConcurrently(SyncMode::kLive, kCameras, GetParam(), kPeriods);
  expectWellFormed(run.sets);
  expectCountsAddUp(run.stats);
  EXPECT_EQ(run.stats.frames_buffered, 0u);
  EXPECT_EQ(run.stats.sets_emitted, run.sets.size());
  for (int c = 0; c < kCameras; ++c) {
    EXPECT_EQ(run.stats.cameras[c].frames_received, static_cast<uint64_t>(kPeriods));
    const auto in_sets = std::count_if(run.sets.begin(), run.sets.end(), [c](const FrameSet& set) {
      return set.frames[c].has_value();
    });
    EXPECT_EQ(run.stats.cameras[c].frames_emitted, static_cast<uint64_t>(in_sets));
  }
}

TEST_P(ConcurrentPushes, ReplayDeliversEveryFrameInCompleteSets) {
  constexpr int kCameras = 4;
  constexpr int kPeriods = 3000;
  const ConcurrentRun run = runConcurrently(SyncMode::kReplay, kCameras, GetParam(), kPeriods);
  ASSERT_EQ(run.sets.size(), static_cast<std::size_t>(kPeriods));
  for (int k = 0; k < kPeriods; ++k) {
    ASSERT_TRUE(run.sets[k].complete()) << "set " << k;
    EXPECT_EQ(run.sets[k].frames[0]->sequence, static_cast<uint64_t>(k));
  }
  expectWellFormed(run.sets);
  expectCountsAddUp(run.stats);
  for (const auto& camera : run.stats.cameras) EXPECT_EQ(camera.droppedTotal(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Threads, ConcurrentPushes, testing::Values(4, 2),
                         [](const testing::TestParamInfo<int>& param_info) {
                           return std::to_string(param_info.param) + "Threads";
                         });

}  // namespace
}  // namespace mocap
