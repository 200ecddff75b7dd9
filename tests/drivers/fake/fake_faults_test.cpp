// The fake scene's faults as a long run needs them: outages that come back, and faults given per
// camera in its device string (how a daemon's configuration sets them).
#include <chrono>
#include <set>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "drivers/fake/fake_driver.h"
#include "tests/drivers/frame_collector.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;

// 50 Hz, as fast as possible, `frames` frames per camera.
FakeDriverOptions smallScene(uint64_t frames) {
  FakeDriverOptions options;
  options.scene.width = 160;
  options.scene.height = 120;
  options.scene.fps = 50;
  options.scene.pacing = FakePacing::kAsFastAsPossible;
  options.scene.frame_limit = frames;
  options.scene.generated_frames = 60;
  return options;
}

CameraConfig sceneCamera(int index, const std::string& device) {
  CameraConfig config;
  config.index = index;
  config.driver = "fake";
  config.device = device;
  config.width = 160;
  config.height = 120;
  config.fps = 50;
  return config;
}

struct Delivered {
  std::set<uint64_t> sequences;
  std::vector<std::string> events;
};

// Everything one camera delivers until its frame limit, and the events it reports.
Delivered runCamera(FakeDriver& driver, const CameraConfig& config, std::size_t expected_frames) {
  FrameCollector collector(std::chrono::seconds(60));
  Expected<std::unique_ptr<Camera>> camera = driver.open(config);
  if (!camera.ok()) {
    ADD_FAILURE() << camera.error();
    return {};
  }
  EXPECT_TRUE(camera.value()->start(collector.frameSink(), collector.eventSink()).ok());
  EXPECT_TRUE(collector.waitForFrames(expected_frames));
  camera.value()->stop();
  Delivered delivered;
  for (const Frame& frame : collector.frames()) delivered.sequences.insert(frame.sequence);
  delivered.events = collector.events();
  return delivered;
}

// Frames [start, start + length) of every `every`, below `limit`.
std::set<uint64_t> repeatedStretches(uint64_t start, uint64_t length, uint64_t every,
                                     uint64_t limit) {
  std::set<uint64_t> frames;
  for (uint64_t from = start; from < limit; from += every)
    for (uint64_t f = from; f < from + length && f < limit; ++f) frames.insert(f);
  return frames;
}

TEST(FakeFaults, AnOutageWithAPeriodComesBack) {
  FakeDriverOptions options = smallScene(100);
  // Frames 10..14, then every 20 frames: 30..34, 50..54, ...
  options.scene.faults.stall = {0, 10, std::chrono::milliseconds(100),
                                std::chrono::milliseconds(400)};
  FakeDriver driver(options);
  const std::set<uint64_t> missing = repeatedStretches(10, 5, 20, 100);
  const Delivered delivered = runCamera(driver, sceneCamera(0, "scene:0"), 100 - missing.size());
  ASSERT_EQ(delivered.sequences.size(), 100 - missing.size());
  for (uint64_t f = 0; f < 100; ++f)
    EXPECT_EQ(delivered.sequences.count(f), missing.count(f) ? 0u : 1u) << f;
  EXPECT_TRUE(delivered.events.empty());  // a stall is silent
}

TEST(FakeFaults, APeriodShorterThanTheOutageStillLeavesAFrame) {
  FakeDriverOptions options = smallScene(40);
  options.scene.faults.stall = {0, 0, std::chrono::milliseconds(100),
                                std::chrono::milliseconds(20)};  // 5 frames, "every 1"
  FakeDriver driver(options);
  const Delivered delivered = runCamera(driver, sceneCamera(0, "scene:0"), 40 / 6);
  EXPECT_EQ(delivered.sequences, repeatedStretches(5, 1, 6, 40));
}

TEST(FakeFaults, TheDeviceStringGivesOneCameraARepeatingDisconnect) {
  FakeDriverOptions options = smallScene(60);
  FakeDriver driver(options);
  // 0.1 s (5 frames) from 0.2 s (frame 10), every 0.4 s (20 frames).
  const Delivered faulty = runCamera(driver, sceneCamera(1, "scene:1?disconnect=0.1@0.2/0.4"), 45);
  EXPECT_EQ(faulty.sequences.size(), 45u);
  for (uint64_t f : repeatedStretches(10, 5, 20, 60)) EXPECT_EQ(faulty.sequences.count(f), 0u) << f;
  ASSERT_EQ(faulty.events.size(), 6u);
  for (std::size_t i = 0; i < 6; i += 2) {
    EXPECT_THAT(faulty.events[i], HasSubstr("scene:1: camera disconnected"));
    EXPECT_THAT(faulty.events[i + 1], HasSubstr("scene:1: camera reconnected"));
  }
  // The other camera of the scene keeps the scene's faults: none.
  const Delivered healthy = runCamera(driver, sceneCamera(0, "scene:0"), 60);
  EXPECT_EQ(healthy.sequences.size(), 60u);
  EXPECT_TRUE(healthy.events.empty());
}

TEST(FakeFaults, TheDeviceStringGivesADropRateAndAStall) {
  FakeDriver driver(smallScene(200));
  // "scene" with a query is the camera of config.index, as plain "scene" is.
  const Delivered delivered =
      runCamera(driver, sceneCamera(1, "scene?drop_rate=0.2&stall=0.2@1"), 120);
  ASSERT_GE(delivered.sequences.size(), 120u);
  for (uint64_t f = 50; f < 60; ++f) EXPECT_EQ(delivered.sequences.count(f), 0u) << f;
  // Frames up to the last delivered one, less the stall's 10 and those delivered.
  const std::size_t dropped = *delivered.sequences.rbegin() + 1 - 10 - delivered.sequences.size();
  EXPECT_GT(dropped, 15u);
  EXPECT_LT(dropped, 60u);
}

TEST(FakeFaults, BadFaultStringsAreNamed) {
  FakeDriver driver(smallScene(10));
  const auto error = [&](const std::string& device) {
    Expected<std::unique_ptr<Camera>> camera = driver.open(sceneCamera(0, device));
    return camera.ok() ? std::string("opened") : camera.error();
  };
  EXPECT_THAT(error("scene:0?stall=2"), HasSubstr("stall: '2' is not <seconds>@<start seconds>"));
  EXPECT_THAT(error("scene:0?disconnect=1@2/1"), HasSubstr("more than the outage"));
  EXPECT_THAT(error("scene:0?drop_rate=1.5"), HasSubstr("drop_rate '1.5' is not a chance"));
  EXPECT_THAT(error("scene:0?jitter=2"), HasSubstr("unknown fault 'jitter'"));
  EXPECT_THAT(error("scene:x?drop_rate=0.1"), HasSubstr("expected scene:<camera index>"));
  EXPECT_EQ(error("scene:0?drop_rate=0.1&stall=1@2/3"), "opened");
}

}  // namespace
}  // namespace mocap
