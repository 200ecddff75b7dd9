// Tests of the frame synchronizer's grouping: jitter, tolerance, clock offsets, rates and arrival
// order; missing and stalled cameras. Time is driven by an injected clock, never by sleeping.
#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "drivers/sync/frame_synchronizer.h"
#include "tests/drivers/sync/frame_synchronizer_test_support.h"

namespace mocap {
namespace {

using namespace std::chrono_literals;
using namespace sync_test;

TEST(FrameSynchronizerConfig, RejectsBadValuesNamingTheField) {
  SyncConfig config = baseConfig(3, SyncMode::kLive);
  config.tolerance = std::chrono::nanoseconds(kPeriod / 2);
  auto created = FrameSynchronizer::create(config);
  ASSERT_FALSE(created.ok());
  EXPECT_NE(created.error().find("tolerance"), std::string::npos) << created.error();

  config = baseConfig(3, SyncMode::kLive);
  config.clock_offsets = {0ns, 1ms};
  created = FrameSynchronizer::create(config);
  ASSERT_FALSE(created.ok());
  EXPECT_NE(created.error().find("clock_offsets"), std::string::npos) << created.error();

  config = baseConfig(3, SyncMode::kLive);
  config.frames_per_camera = 2;
  created = FrameSynchronizer::create(config);
  ASSERT_FALSE(created.ok());
  EXPECT_NE(created.error().find("frames_per_camera"), std::string::npos) << created.error();

  EXPECT_TRUE(FrameSynchronizer::create(baseConfig(3, SyncMode::kLive)).ok());
}

TEST(FrameSynchronizer, GroupsJitteredFramesWithinTolerance) {
  auto sync = makeSync(baseConfig(3, SyncMode::kReplay));
  const int64_t jitter[3][4] = {{0, 4, -3, 5}, {-5, 0, 6, -2}, {3, -6, 0, 1}};  // ms, spread <= 12
  std::vector<FrameSet> sets;
  for (int k = 0; k < 40; ++k) {
    for (int c = 0; c < 3; ++c) {
      pushAndCollect(*sync, makeFrame(c, k, slot(k) + jitter[c][k % 4] * kMs), sets);
    }
  }
  ASSERT_EQ(sets.size(), 40u);
  for (int k = 0; k < 40; ++k) {
    EXPECT_TRUE(sets[k].complete()) << "set " << k;
    EXPECT_EQ(sets[k].sequence, static_cast<uint64_t>(k));
    EXPECT_NEAR(static_cast<double>(sets[k].timestamp_ns), static_cast<double>(slot(k)), 6.0 * kMs);
  }
  expectWellFormed(sets);
  const SyncStats stats = sync->stats();
  for (const auto& camera : stats.cameras) EXPECT_EQ(camera.droppedTotal(), 0u);
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, FrameBeyondToleranceIsUnmatchedAndItsSetIncomplete) {
  auto sync = makeSync(baseConfig(3, SyncMode::kReplay));
  std::vector<FrameSet> sets;
  for (int k = 0; k < 6; ++k) {
    for (int c = 0; c < 3; ++c) {
      const int64_t shift = (k == 3 && c == 2) ? 20 * kMs : 0;  // half a period off
      pushAndCollect(*sync, makeFrame(c, k, slot(k) + shift), sets);
    }
  }
  ASSERT_EQ(sets.size(), 6u);
  EXPECT_FALSE(sets[3].frames[2].has_value());
  EXPECT_EQ(sets[3].presentCount(), 2);
  const SyncStats stats = sync->stats();
  EXPECT_EQ(stats.sets_incomplete, 1u);
  EXPECT_EQ(stats.cameras[2].droppedBy(DropCause::kUnmatched), 1u);
  expectWellFormed(sets);
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, ClockOffsetsBringCamerasIntoOneTimeBase) {
  // Camera 1 stamps 1.5 s ahead and camera 2 7 ms behind the rig.
  const std::vector<int64_t> camera_error = {0, 1'500 * kMs, -7 * kMs};
  const auto run = [&](bool with_offsets) {
    ManualClock clock;  // frozen: only arrivals decide sets
    SyncConfig config = baseConfig(3, SyncMode::kLive);
    config.clock = clock.source();
    if (with_offsets) {
      for (int64_t error : camera_error)
        config.clock_offsets.push_back(std::chrono::nanoseconds(-error));
    }
    auto sync = makeSync(config);
    std::vector<FrameSet> sets;
    for (int k = 0; k < 10; ++k) {
      for (int c = 0; c < 3; ++c)
        pushAndCollect(*sync, makeFrame(c, k, slot(k) + camera_error[c]), sets);
    }
    sync->close();
    for (auto& set : drain(*sync)) sets.push_back(std::move(set));
    return sets;
  };

  const std::vector<FrameSet> aligned = run(true);
  ASSERT_EQ(aligned.size(), 10u);
  for (int k = 0; k < 10; ++k) {
    EXPECT_TRUE(aligned[k].complete());
    EXPECT_EQ(aligned[k].timestamp_ns, slot(k));  // the rig's time base
    EXPECT_EQ(aligned[k].frames[1]->timestamp_ns, slot(k) + camera_error[1]);  // as delivered
  }
  std::vector<int64_t> offsets;
  for (int64_t error : camera_error) offsets.push_back(-error);
  expectWellFormed(aligned, offsets);

  const std::vector<FrameSet> unaligned = run(false);
  EXPECT_TRUE(std::none_of(unaligned.begin(), unaligned.end(),
                           [](const FrameSet& set) { return set.complete(); }));
}

// Camera 2 loses frame 5: the set is decided as soon as camera 2 delivers frame 6.
std::vector<FrameSet> runWithLostFrame(FrameSynchronizer& sync) {
  std::vector<FrameSet> sets;
  for (int k = 0; k < 10; ++k) {
    for (int c = 0; c < 3; ++c) {
      if (c == 2 && k == 5) continue;
      pushAndCollect(sync, makeFrame(c, k, slot(k)), sets);
    }
  }
  return sets;
}

TEST(FrameSynchronizer, LostFrameGivesIncompleteSetUnderEmitPolicy) {
  auto sync = makeSync(baseConfig(3, SyncMode::kReplay));
  const std::vector<FrameSet> sets = runWithLostFrame(*sync);
  ASSERT_EQ(sets.size(), 10u);
  EXPECT_FALSE(sets[5].complete());
  EXPECT_FALSE(sets[5].frames[2].has_value());
  EXPECT_EQ(sets[5].frames[0]->sequence, 5u);
  const SyncStats stats = sync->stats();
  EXPECT_EQ(stats.sets_complete, 9u);
  EXPECT_EQ(stats.sets_incomplete, 1u);
  EXPECT_EQ(stats.cameras[2].sets_missed, 1u);
  expectWellFormed(sets);
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, LostFrameSkipsSetUnderSkipPolicyLeavingASequenceGap) {
  SyncConfig config = baseConfig(3, SyncMode::kReplay);
  config.incomplete_policy = IncompletePolicy::kSkip;
  auto sync = makeSync(config);
  const std::vector<FrameSet> sets = runWithLostFrame(*sync);
  ASSERT_EQ(sets.size(), 9u);
  for (const auto& set : sets) EXPECT_TRUE(set.complete());
  EXPECT_EQ(sets[4].sequence, 4u);
  EXPECT_EQ(sets[5].sequence, 6u);
  const SyncStats stats = sync->stats();
  EXPECT_EQ(stats.sets_skipped, 1u);
  EXPECT_EQ(stats.cameras[0].droppedBy(DropCause::kIncompleteSkipped), 1u);
  EXPECT_EQ(stats.cameras[1].droppedBy(DropCause::kIncompleteSkipped), 1u);
  EXPECT_EQ(stats.cameras[2].droppedTotal(), 0u);
  expectWellFormed(sets);
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, StalledCameraIsReleasedByTheDeadlineThenNotWaitedFor) {
  ManualClock clock;
  SyncConfig config = baseConfig(2, SyncMode::kLive);
  config.clock = clock.source();
  auto sync = makeSync(config);
  const auto deliver = [&](int camera, int k) {
    clock.now = std::max(clock.now.load(), slot(k) + 1 * kMs);  // delivered 1 ms after exposure
    sync->push(makeFrame(camera, k, slot(k)));
  };

  for (int k = 0; k < 4; ++k) {
    deliver(0, k);
    deliver(1, k);
    auto set = sync->pop(0ns);
    ASSERT_TRUE(set && set->complete()) << "period " << k;
  }

  deliver(0, 4);  // camera 1 stalls from here
  EXPECT_FALSE(sync->pop(0ns).has_value());
  clock.now = slot(4) + kDeadline - 1;
  EXPECT_FALSE(sync->pop(0ns).has_value()) << "released before its deadline";
  clock.now = slot(4) + kDeadline;
  auto released = sync->pop(0ns);
  ASSERT_TRUE(released.has_value());
  EXPECT_EQ(released->frames[0]->sequence, 4u);
  EXPECT_FALSE(released->frames[1].has_value());

  for (int k = 5; k < 8; ++k) {  // the stalled camera no longer holds sets back
    deliver(0, k);
    auto set = sync->pop(0ns);
    ASSERT_TRUE(set.has_value()) << "period " << k;
    EXPECT_FALSE(set->frames[1].has_value());
  }

  sync->push(makeFrame(1, 4, slot(4)));  // the stalled camera's overdue frame turns up
  deliver(0, 8);
  EXPECT_FALSE(sync->pop(0ns).has_value()) << "camera 1 is back and must be waited for";
  deliver(1, 8);
  auto resumed = sync->pop(0ns);
  ASSERT_TRUE(resumed.has_value());
  EXPECT_TRUE(resumed->complete());

  const SyncStats stats = sync->stats();
  EXPECT_EQ(stats.sets_complete, 5u);
  EXPECT_EQ(stats.sets_incomplete, 4u);
  EXPECT_EQ(stats.cameras[1].sets_missed, 4u);
  EXPECT_EQ(stats.cameras[1].droppedBy(DropCause::kLate), 1u);
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, FasterCameraExtraFramesAreDroppedAsUnmatched) {
  auto sync = makeSync(baseConfig(3, SyncMode::kReplay));
  constexpr int kPeriods = 20;
  std::vector<FrameSet> sets;
  for (int k = 0; k < kPeriods; ++k) {  // cameras 0 and 1 at 25 Hz, camera 2 at 50 Hz
    pushAndCollect(*sync, makeFrame(0, k, slot(k)), sets);
    pushAndCollect(*sync, makeFrame(1, k, slot(k)), sets);
    pushAndCollect(*sync, makeFrame(2, 2 * k, slot(k)), sets);
    pushAndCollect(*sync, makeFrame(2, 2 * k + 1, slot(k) + kPeriod / 2), sets);
  }
  sync->close();
  for (auto& set : drain(*sync)) sets.push_back(std::move(set));

  ASSERT_EQ(sets.size(), static_cast<std::size_t>(kPeriods));
  for (int k = 0; k < kPeriods; ++k) {
    EXPECT_TRUE(sets[k].complete()) << "set " << k;
    EXPECT_EQ(sets[k].frames[2]->sequence, static_cast<uint64_t>(2 * k));
  }
  const SyncStats stats = sync->stats();
  EXPECT_EQ(stats.cameras[2].droppedBy(DropCause::kUnmatched), static_cast<uint64_t>(kPeriods));
  EXPECT_EQ(stats.cameras[0].droppedTotal(), 0u);
  expectWellFormed(sets);
  expectCountsAddUp(stats);
}

TEST(FrameSynchronizer, CameraArrivingLateRelativeToOthersStillGroups) {
  ManualClock clock;
  SyncConfig config = baseConfig(3, SyncMode::kLive);
  config.clock = clock.source();
  config.deadline = std::chrono::nanoseconds(4 * kPeriod);
  auto sync = makeSync(config);
  constexpr int kLag = 3;  // camera 0's frames reach us three periods after the others'
  std::vector<FrameSet> sets;
  for (int k = 0; k < 30 + kLag; ++k) {
    clock.now = slot(k) + 2 * kMs;
    if (k < 30) {
      pushAndCollect(*sync, makeFrame(2, k, slot(k)), sets);
      pushAndCollect(*sync, makeFrame(1, k, slot(k)), sets);
    }
    if (k >= kLag) pushAndCollect(*sync, makeFrame(0, k - kLag, slot(k - kLag)), sets);
  }
  ASSERT_EQ(sets.size(), 30u);
  for (const auto& set : sets) EXPECT_TRUE(set.complete());
  expectWellFormed(sets);
  expectCountsAddUp(sync->stats());
}

TEST(FrameSynchronizer, RandomJitterLossAndArrivalOrderKeepSetsWellFormed) {
  constexpr int kCameras = 4;
  constexpr int kPeriods = 500;
  std::mt19937 random(7);
  std::uniform_int_distribution<int64_t> jitter(-5 * kMs, 5 * kMs);
  std::uniform_int_distribution<int64_t> latency(0, 100 * kMs);  // beyond the deadline at times
  std::bernoulli_distribution lost(0.1);

  struct Arrival {
    int64_t at_ns;
    Frame frame;
  };
  std::vector<Arrival> arrivals;
  for (int c = 0; c < kCameras; ++c) {
    int64_t previous_arrival = 0;
    for (int k = 0; k < kPeriods; ++k) {
      if (lost(random)) continue;
      const int64_t exposure = slot(k) + jitter(random);
      const int64_t at = std::max(previous_arrival + 1, exposure + latency(random));
      previous_arrival = at;
      arrivals.push_back({at, makeFrame(c, k, exposure)});
    }
  }
  std::sort(arrivals.begin(), arrivals.end(),
            [](const Arrival& a, const Arrival& b) { return a.at_ns < b.at_ns; });

  ManualClock clock;
  SyncConfig config = baseConfig(kCameras, SyncMode::kLive);
  config.clock = clock.source();
  auto sync = makeSync(config);
  std::vector<FrameSet> sets;
  for (auto& arrival : arrivals) {
    clock.now = arrival.at_ns;
    pushAndCollect(*sync, std::move(arrival.frame), sets);
  }
  sync->close();
  for (auto& set : drain(*sync)) sets.push_back(std::move(set));

  expectWellFormed(sets);
  const SyncStats stats = sync->stats();
  expectCountsAddUp(stats);
  EXPECT_EQ(stats.frames_buffered, 0u);
  EXPECT_GT(stats.sets_complete, static_cast<uint64_t>(kPeriods / 4));
  EXPECT_GT(stats.sets_incomplete, 0u);
  uint64_t late = 0;
  for (const auto& camera : stats.cameras) late += camera.droppedBy(DropCause::kLate);
  EXPECT_GT(late, 0u) << "the scenario is meant to exercise late frames";
}

}  // namespace
}  // namespace mocap
