// The fake driver's replay source: recorded sessions played by replay cameras and by the pump into
// a replay-mode synchronizer, exactly and deterministically.
#include <unistd.h>

#include <filesystem>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "drivers/fake/fake_driver.h"
#include "drivers/fake/replay_pump.h"
#include "drivers/record/recorder.h"
#include "tests/drivers/frame_collector.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kWidth = 160;
constexpr int kHeight = 120;
constexpr int kSets = 12;

// A session recorded from the fake scene: camera 1 misses set 4, camera 0 ends one set early.
class ReplayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("mocap_replay_test_" + std::to_string(::getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
    FakeSceneOptions options;
    options.width = kWidth;
    options.height = kHeight;
    options.generated_frames = 20;
    scene_ = FakeScene::create(options).value();
    Recorder recorder(root_, {.queue_sets = kSets});  // keeps every set: the test needs them all
    const std::vector<SessionCamera> cameras = {{"cam0", kWidth, kHeight, kPixelBgr, 25},
                                                {"cam1", kWidth, kHeight, kPixelBgr, 25}};
    ASSERT_TRUE(recorder.open("take", scene_->rig(), cameras).ok());
    for (int n = 0; n < kSets; ++n) {
      FrameSet set;
      set.sequence = static_cast<uint64_t>(n);
      set.timestamp_ns = 5'000'000'000 + n * 40'000'000;
      set.frames.resize(2);
      for (int c = 0; c < 2; ++c) {
        if ((c == 1 && n == 4) || (c == 0 && n == kSets - 1)) continue;
        FakeRenderScratch scratch(scene_->model(), kHeight);
        Frame f;
        f.camera = c;
        f.sequence = static_cast<uint64_t>(n);
        f.timestamp_ns = set.timestamp_ns + (c == 0 ? -300 : 300);
        f.dropped_before = c == 1 && n == 5 ? 1 : 0;
        scene_->render(c, static_cast<uint64_t>(n), scratch, f.image);
        set.frames[c] = std::move(f);
      }
      recorder.write(set);
    }
    ASSERT_TRUE(recorder.close().ok());
    session_ = recorder.sessionPath();
  }
  void TearDown() override { fs::remove_all(root_); }

  CameraConfig replayCamera(int index, int session_camera) const {
    CameraConfig config;
    config.index = index;
    config.driver = "fake";
    config.device = "replay:" + session_.string() + ":" + std::to_string(session_camera);
    config.width = kWidth;
    config.height = kHeight;
    return config;
  }

  fs::path root_;
  fs::path session_;
  std::shared_ptr<FakeScene> scene_;
};

std::vector<Frame> playCamera(FakeDriver& driver, const CameraConfig& config, std::size_t count,
                              std::vector<std::string>* events = nullptr) {
  Expected<std::unique_ptr<Camera>> camera = driver.open(config);
  EXPECT_TRUE(camera.ok()) << camera.error();
  if (!camera.ok()) return {};
  FrameCollector received(std::chrono::seconds(60));
  const Status started = camera.value()->start(received.frameSink(), received.eventSink());
  EXPECT_TRUE(started.ok());
  received.waitForFrames(count);
  camera.value()->stop();
  if (events) *events = received.events();
  return received.frames();
}

TEST_F(ReplayTest, ReplayCameraReproducesTheRecordingExactly) {
  FakeDriver driver({.scene = {}, .replay = {.real_time = false, .loop = false, .read = {}}});
  std::vector<std::string> events;
  const std::vector<Frame> frames = playCamera(driver, replayCamera(3, 1), kSets - 1, &events);
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kSets - 1));
  FakeRenderScratch scratch(scene_->model(), kHeight);
  std::size_t i = 0;
  for (int n = 0; n < kSets; ++n) {
    if (n == 4) continue;
    const Frame& f = frames[i++];
    EXPECT_EQ(f.camera, 3);
    EXPECT_EQ(f.sequence, static_cast<uint64_t>(n));
    EXPECT_EQ(f.timestamp_ns, 5'000'000'000 + n * 40'000'000 + 300);
    EXPECT_EQ(f.dropped_before, n == 5 ? 1u : 0u);
    cv::Mat original;
    scene_->render(1, static_cast<uint64_t>(n), scratch, original);
    EXPECT_EQ(cv::norm(f.image, original, cv::NORM_INF), 0.0);
  }
  ASSERT_FALSE(events.empty());
  EXPECT_THAT(events.back(), HasSubstr("end of the recorded session"));
}

TEST_F(ReplayTest, RealTimeLoopingReplayKeepsTimeMovingForward) {
  FakeDriver driver({.scene = {}, .replay = {.real_time = true, .loop = true, .read = {}}});
  const std::vector<Frame> frames = playCamera(driver, replayCamera(0, 0), 2 * (kSets - 1) + 2);
  ASSERT_GE(frames.size(), static_cast<std::size_t>(2 * (kSets - 1) + 2));
  for (std::size_t i = 1; i < frames.size(); ++i) {
    EXPECT_GT(frames[i].timestamp_ns, frames[i - 1].timestamp_ns);
    EXPECT_GT(frames[i].sequence, frames[i - 1].sequence);
  }
  EXPECT_EQ(frames[0].timestamp_ns, 5'000'000'000 - 300);  // the first pass is exact
}

TEST_F(ReplayTest, BadSessionFailsAtOpenNamingTheFileAndFrame) {
  fs::remove(session_ / "cam0" / "000002.png");
  FakeDriver driver;
  Expected<std::unique_ptr<Camera>> camera = driver.open(replayCamera(0, 0));
  ASSERT_FALSE(camera.ok());
  EXPECT_THAT(camera.error(), HasSubstr("cam0/000002.png: frame 2 of camera 0 (set 2)"));
}

// Pops every set the pump produces into a string: what a determinism check compares.
std::vector<std::string> pumpAndCollect(const SessionReader& reader) {
  SyncConfig config;
  config.camera_count = 2;
  config.mode = SyncMode::kReplay;
  config.frames_per_camera = 3;  // the least the deadline allows: the pump really waits on the consumer
  config.replay_queue_sets = 1;
  Expected<std::unique_ptr<FrameSynchronizer>> created = FrameSynchronizer::create(config);
  EXPECT_TRUE(created.ok()) << created.error();
  if (!created.ok()) return {};
  std::unique_ptr<FrameSynchronizer> sync = std::move(created.value());
  Status pumped = Status::Ok();
  std::thread pump([&] { pumped = pumpSession(reader, *sync, {.real_time = false, .loops = 2}); });
  std::vector<std::string> sets;
  while (std::optional<FrameSet> set = sync->pop(std::chrono::seconds(60))) {
    std::string text = std::to_string(set->timestamp_ns) + ":";
    for (const std::optional<Frame>& f : set->frames) {
      text += f ? " " + std::to_string(f->sequence) + "@" + std::to_string(f->timestamp_ns) : " -";
    }
    sets.push_back(text);
  }
  pump.join();
  EXPECT_TRUE(pumped.ok()) << pumped.message();
  EXPECT_EQ(sync->stats().cameras[0].droppedTotal() + sync->stats().cameras[1].droppedTotal(), 0u);
  return sets;
}

TEST_F(ReplayTest, PumpIntoReplaySynchronizerIsDeterministic) {
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(session_);
  ASSERT_TRUE(reader.ok()) << reader.error();
  const std::vector<std::string> first = pumpAndCollect(*reader.value());
  ASSERT_EQ(first.size(), static_cast<std::size_t>(2 * kSets));  // two loops
  EXPECT_THAT(first[4], HasSubstr(" -"));                         // camera 1 missed set 4
  EXPECT_THAT(first[kSets - 1], HasSubstr(": -"));                // camera 0 ended early
  for (int run = 0; run < 3; ++run) EXPECT_EQ(pumpAndCollect(*reader.value()), first);
}

}  // namespace
}  // namespace mocap
