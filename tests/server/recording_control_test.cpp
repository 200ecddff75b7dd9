// The daemon's recordings by image mode and on a filling disk: a start refused under the free-space
// floor, a recording stopped at it with a status, and replays of compressed sessions and of
// sessions without images; and the recording control's status, read without its lock.
#include "server/recording_control.h"

#include <sys/mount.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "drivers/record/session_reader.h"
#include "server/mocap_server.h"
#include "server/server_test_support.h"
#include "tracker/model/builtin_models.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using test::EndToEndTest;
using test::freshDirectory;
using test::startServer;
using ::testing::HasSubstr;

// The answer to StartRecording once the cameras have sent frames (retried while they have not).
grpc::Status startWhenCamerasAre(v1::MocapService::Stub& stub, const std::string& path) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  for (;;) {
    grpc::ClientContext context;
    v1::StartRecordingRequest request;
    request.set_path(path);
    v1::RecordingState state;
    const grpc::Status status = stub.StartRecording(&context, request, &state);
    if (status.error_message().find("has sent no frame yet") == std::string::npos ||
        std::chrono::steady_clock::now() > give_up)
      return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

TEST_F(EndToEndTest, RefusesToStartARecordingUnderTheFreeSpaceFloor) {
  const fs::path root = freshDirectory("floor_start");
  ServerConfig config = test::sceneConfig();
  config.recording_directory = fs::canonical(root).string();
  config.recording.min_free_mb = 100'000'000;  // 100 TB
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const grpc::Status status = startWhenCamerasAre(*stub, "session");
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), HasSubstr("under the floor of 100000000 MB"));
  EXPECT_FALSE(fs::exists(root / "session"));
  server->shutdown();
  fs::remove_all(root);
}

// On a 512 MB tmpfs with a 400 MB floor, a lossless recording (the two backgrounds, tens of MB,
// then about 1.2 MB a frame) stops within seconds; the status and StopRecording say why, and the
// session holds what the status counted.
TEST_F(EndToEndTest, StopsARecordingAtTheFreeSpaceFloor) {
  const fs::path root = freshDirectory("floor_stop");
  if (::mount("tmpfs", root.c_str(), "tmpfs", 0, "size=512m") != 0)
    GTEST_SKIP() << "mounting a tmpfs is not permitted here (" << std::strerror(errno)
                 << "); drivers.record.disk_floor_test covers the floor without it";
  ServerConfig config = test::sceneConfig();
  config.recording_directory = fs::canonical(root).string();
  config.recording.min_free_mb = 400;
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  ASSERT_TRUE(startWhenCamerasAre(*stub, "session").ok());
  v1::Status status;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  do {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    grpc::ClientContext context;
    ASSERT_TRUE(stub->GetStatus(&context, {}, &status).ok());
  } while (status.recording().active() && std::chrono::steady_clock::now() < give_up);
  EXPECT_FALSE(status.recording().active());
  EXPECT_GT(status.recording().frame_sets(), 0u);
  grpc::ClientContext context;
  v1::RecordingState state;
  const grpc::Status stop = stub->StopRecording(&context, {}, &state);
  EXPECT_EQ(stop.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(stop.error_message(), HasSubstr("session stopped on its own"));
  EXPECT_THAT(stop.error_message(), HasSubstr("under the floor of 400 MB"));
  server->shutdown();
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(root / "session");
  ASSERT_TRUE(reader.ok()) << reader.error();
  EXPECT_EQ(reader.value()->sets().size(), status.recording().frame_sets());
  ::umount2(root.c_str(), MNT_DETACH);
  fs::remove_all(root);
}

// Records 40 sets of the scene with `images`, replays the session (thresholding frames without a
// background, as a session without images needs) and returns the median agreement
// (intersection over union) of the replay's silhouettes with the recorded ones, and the poses.
std::pair<double, std::size_t> recordAndReplay(ImageMode images, const std::string& name) {
  const fs::path root = freshDirectory(name);
  {
    ServerConfig config = test::sceneConfig();
    config.recording_directory = fs::canonical(root).string();
    config.recording.images = images;
    std::unique_ptr<MocapServer> server = startServer(config);
    EXPECT_TRUE(server);
    if (!server) return {0, 0};
    auto stub = test::connect(server->port());
    test::record(*stub, "session", 40);
    server->shutdown();
  }
  ServerConfig config = test::sceneConfig();
  config.replay_directory = (root / "session").string();
  config.as_fast_as_possible = true;
  config.threshold_before_background = true;
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  EXPECT_TRUE(server.ok()) << server.error();
  if (!server.ok()) return {0, 0};
  // Per camera and frame sequence, the silhouettes the replay tracked on.
  std::mutex mutex;
  std::map<std::pair<int, uint64_t>, cv::Mat> masks;
  std::size_t poses = 0;
  server.value()->pipeline().setPoseObserver([&](const Pose&) { ++poses; });
  server.value()->pipeline().setMaskObserver(
      [&](const FrameSet& set, const std::vector<SilhouetteMask>& tracked) {
        std::lock_guard lock(mutex);
        for (int c = 0; c < 2; ++c)
          if (set.frames[c]) masks[{c, set.frames[c]->sequence}] = tracked[c].toMat();
      });
  EXPECT_TRUE(server.value()->start().ok());
  server.value()->pipeline().waitForReplayEnd();
  server.value()->shutdown();

  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(root / "session");
  EXPECT_TRUE(reader.ok()) << reader.error();
  std::vector<double> agreement;
  for (std::size_t s = 0; reader.ok() && s < reader.value()->sets().size(); ++s) {
    for (int c = 0; c < 2; ++c) {
      const auto& frame = reader.value()->sets()[s].frames[c];
      const auto mask = frame ? masks.find({c, frame->camera_sequence}) : masks.end();
      Expected<cv::Mat> recorded = reader.value()->readSilhouette(s, c);
      if (mask == masks.end() || !recorded.ok() || recorded.value().empty()) continue;
      const double both = cv::countNonZero(mask->second & recorded.value());
      const double either = cv::countNonZero(mask->second | recorded.value());
      agreement.push_back(either == 0 ? 1.0 : both / either);
    }
  }
  fs::remove_all(root);
  EXPECT_GE(agreement.size(), 70u);  // 40 sets of 2 cameras, less a few at the start
  return {test::median(std::move(agreement)), poses};
}

TEST_F(EndToEndTest, ReplaysASessionWithoutImagesOnItsRecordedSilhouettes) {
  const auto [agreement, poses] = recordAndReplay(ImageMode::kNone, "replay_none");
  EXPECT_EQ(agreement, 1.0);  // exactly the recorded silhouettes
  EXPECT_GT(poses, 30u);
}

TEST_F(EndToEndTest, ReplaysACompressedSessionCloseToItsRecordedSilhouettes) {
  const auto [agreement, poses] = recordAndReplay(ImageMode::kCompressed, "replay_compressed");
  std::printf("compressed replay against the silhouettes of the captured images: IoU %.4f\n",
              agreement);
  EXPECT_GE(agreement, 0.9);  // extracted from the JPEG images instead of the captured ones
  EXPECT_GT(poses, 30u);
}

// The web view reads the status on a thread at idle priority: were the read to take the lock the
// mask thread's tap() takes every frame set (and holds while it takes the recorder's, which its
// writers take), a view thread preempted inside it would stall the mask thread. A status read
// completes while tap() is inside that lock, and says what the recording is before, during and
// after.
TEST(RecordingControl, ReadsTheStatusWithoutTheControlLock) {
  const fs::path root = freshDirectory("status_without_lock");
  ServerConfig config;
  config.recording_directory = fs::canonical(root).string();
  config.recording.min_free_mb = 0;
  std::vector<OpenedCamera> cameras(1);
  cameras[0].info.id = "gray";
  cameras[0].config.width = 8;
  cameras[0].config.height = 8;
  cameras[0].config.fps = 25;
  const BodyModel body = builtinHandModel();
  // tap() asks for a recorded set's truth under the control lock: once block_next is set, the
  // next set's truth waits there until released.
  std::atomic<bool> block_next{false};
  std::promise<void> inside_tap, release_tap;
  std::shared_future<void> released = release_tap.get_future().share();
  RecordedTracking tracking;
  tracking.configured_body = &body;
  tracking.tracked_body = [] { return TrackedBody{}; };
  tracking.truth = [&](uint64_t) {
    if (block_next.exchange(false)) {
      inside_tap.set_value();
      released.wait();
    }
    return Eigen::VectorXd(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(body.dofs.size())));
  };
  const Rig rig;
  RecordingControl recording(config, rig, cameras, std::move(tracking), {});
  uint64_t sequence = 0;
  const auto tap = [&] {
    FrameSet set;
    set.frames.push_back(Frame{0, ++sequence, 0, 0, false, cv::Mat(8, 8, CV_8UC1, cv::Scalar(0))});
    recording.tap(set, sequence);
  };
  tap();  // the camera's first frame: a session can describe it from now on
  EXPECT_FALSE(recording.status().active);

  const RecordingResult started = recording.start("take");
  ASSERT_EQ(started.error, RecordingError::kNone) << started.message;
  RecordingStatus status = recording.status();
  EXPECT_TRUE(status.active);
  EXPECT_EQ(status.path, "take");
  tap();

  block_next = true;
  std::thread mask_thread(tap);
  inside_tap.get_future().wait();  // tap() now holds the control lock
  std::future<RecordingStatus> read =
      std::async(std::launch::async, [&] { return recording.status(); });
  // Not a speed bound: only turns a read that waits for the lock (for ever, here) into a failure.
  const bool answered = read.wait_for(std::chrono::seconds(30)) == std::future_status::ready;
  release_tap.set_value();
  mask_thread.join();
  ASSERT_TRUE(answered) << "status() waited for the lock tap() holds";
  status = read.get();
  EXPECT_TRUE(status.active);
  EXPECT_EQ(status.path, "take");

  const RecordingResult stopped = recording.stop();
  ASSERT_EQ(stopped.error, RecordingError::kNone) << stopped.message;
  EXPECT_EQ(stopped.status.frame_sets, 2u);
  status = recording.status();
  EXPECT_FALSE(status.active);
  EXPECT_EQ(status.path, "take");
  EXPECT_EQ(status.frame_sets, 2u);
  EXPECT_TRUE(status.stopped.empty()) << status.stopped;
  fs::remove_all(root);
}

}  // namespace
}  // namespace mocap
