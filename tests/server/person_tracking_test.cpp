// End to end with a person in the fake scene (the CMU walk on the built-in human): tracked from its
// true start, found without it, tracked on extracted silhouettes once the empty room is learnt,
// found again on request; the body as configured (speed limits per frame at the cameras' rate, a
// body file, the gait DOFs); a refinement giving way to the next set live; a scene motion that
// does not load.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "drivers/builtin_drivers.h"
#include "drivers/record/session_reader.h"
#include "server/mocap_server.h"
#include "server/server_test_support.h"
#include "server/tls_test_support.h"
#include "tracker/model/builtin_models.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/retarget.h"
#include "tracker/search/body_size.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using test::EndToEndTest;
using test::freshDirectory;
using test::median;
using test::mocapctl;
using test::python;
using test::readPoses;
using test::record;
using test::replay;
using test::skeletonOf;
using test::startServer;
using test::walkingPersonConfig;

TEST_F(EndToEndTest, TracksAPersonWalkingInTheFakeScene) {
  const ServerConfig config = walkingPersonConfig();
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const v1::Skeleton skeleton = skeletonOf(*stub);
  EXPECT_EQ(skeleton.dofs_size(), 31);
  EXPECT_EQ(skeleton.points_size(), 19);

  const std::vector<v1::Pose> poses = readPoses(*stub, 50);
  ASSERT_EQ(poses.size(), 50u);
  for (const v1::Pose& pose : poses) ASSERT_TRUE(pose.has_reference_error_mm());
  // The person is tracked: the median joint is within 50 mm of the truth over the first 2 s (the
  // experiment's 200-frame walk measures 33 mm; a lost body is 100 mm and more).
  EXPECT_LT(median(poses, &v1::Pose::reference_error_mm), 50.0);

  // The status names the tracker settings in use: the people defaults here.
  grpc::ClientContext status_context;
  v1::Status status;
  ASSERT_TRUE(stub->GetStatus(&status_context, {}, &status).ok());
  const auto& settings = status.tracker_settings();
  const auto setting = [&](const std::string& key) {
    const auto found = settings.find(key);
    return found == settings.end() ? std::string("<missing>") : found->second;
  };
  EXPECT_EQ(setting("evaluations"), std::to_string(config.tracker.filter.evaluations_per_frame));
  EXPECT_EQ(setting("lookahead"), "body");
  EXPECT_EQ(setting("refine_plant"), "true");
  EXPECT_EQ(setting("threads"), std::to_string(config.tracker.threads));
}

// As on real cameras, the tracker is not told where the person starts: it finds them in the
// first frame sets' silhouettes, then tracks them.
TEST_F(EndToEndTest, FindsAndTracksAPersonItIsNotToldTheStartOf) {
  ServerConfig config = walkingPersonConfig();
  config.tracker.start = "acquire";
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const std::vector<v1::Pose> poses = readPoses(*stub, 50);
  ASSERT_EQ(poses.size(), 50u);
  // Both measures below are medians over the first 2 s, as from the true pose, not over the last
  // second alone: this walk's frames 28-35 and 45-50 lose the heading for a while even from the
  // true pose (50-130 mm in the experiment).
  // Every pose says how well it explains the silhouettes; tracked, the fake scene's are well
  // explained (its true poses score about 0.97).
  for (const v1::Pose& pose : poses) ASSERT_TRUE(pose.has_silhouette_fit());
  EXPECT_GT(median(poses, &v1::Pose::silhouette_fit), 0.85);
  // The neutral stance at the origin, where it would start otherwise, is metres off. Found, the
  // person is tracked as from the true pose: the median joint within 50 mm.
  EXPECT_LT(median(poses, &v1::Pose::reference_error_mm), 50.0);
  grpc::ClientContext status_context;
  v1::Status status;
  ASSERT_TRUE(stub->GetStatus(&status_context, {}, &status).ok());
  EXPECT_TRUE(status.tracking());
  // Found, then challenged every `challenge_every` (10) sets: those find it again too.
  EXPECT_GE(status.acquisitions(), 2u);
  EXPECT_EQ(status.losses(), 0u);
  EXPECT_EQ(status.search_failure(), "");
  EXPECT_EQ(status.tracker_settings().at("start"), "acquire");
  const std::string python_poses =
      python("stream --count 1 --server 127.0.0.1:" + std::to_string(server->port()));
  EXPECT_THAT(python_poses, ::testing::HasSubstr("\"silhouette_fit\": 0."));
}

// A session as on real cameras: the room is empty at first, the background is captured then
// (the Python client's background, then mocapctl's), the person walks in, and the tracker finds and
// tracks them on the silhouettes extracted from the cameras' images, not the scene's true ones.
TEST_F(EndToEndTest, TracksAPersonOnExtractedSilhouettesAfterTheEmptyRoomIsLearnt) {
  ServerConfig config = walkingPersonConfig();
  // Long enough for two clients to start and capture 25 frames on a loaded machine: the scene
  // runs in real time, and a capture that overlaps the entrance warns, rightly.
  config.scene_empty_seconds = 5;
  config.true_silhouettes = false;
  config.tracker.start = "acquire";
  constexpr uint64_t kEntranceFrame = 125;  // 5 s at 25 Hz
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  EXPECT_EQ(python("background --frames 5 --server " + address),
            "{\"frames_used\": 5, \"warnings\": []}\n");
  const std::string learnt = mocapctl("background --frames 20 --server " + address);
  EXPECT_THAT(learnt, ::testing::HasSubstr("\"frames_used\": 20")) << learnt;
  EXPECT_THAT(learnt, ::testing::HasSubstr("\"silhouettes\": \"background captured\""));
  EXPECT_THAT(learnt, ::testing::HasSubstr("\"warnings\": []"));  // the room was empty

  auto stub = test::connect(server->port());
  const std::vector<v1::Pose> poses = readPoses(*stub, 50, [&](const v1::Pose& pose) {
    // Before the person is in view there is no truth to compare with.
    EXPECT_EQ(pose.has_reference_error_mm(), pose.frame_sequence() >= kEntranceFrame)
        << pose.frame_sequence();
    return pose.frame_sequence() >= kEntranceFrame;
  });
  ASSERT_EQ(poses.size(), 50u);
  // Tracked as on the true silhouettes, where the extraction failing gives 1.4 m (thresholded
  // images, no background). The median joint over the first 2 s: 18.8-45.3 mm in ten runs here,
  // 54.7 once in CI and 50.6 once under ctest -j2 (the walk's kneel, in the first 4 s, is lost in
  // some runs whatever the silhouettes, and a loaded machine skips frame sets). Bounded at 75 mm,
  // above that spread and far below a failed extraction; the accuracy itself is measured by the
  // benches in tracker/experiments/log/service.md.
  const double error = median(poses, &v1::Pose::reference_error_mm);
  std::printf("extracted silhouettes: median error %.1f mm over the first 50 poses\n", error);
  EXPECT_LT(error, 75.0);
  grpc::ClientContext status_context;
  v1::Status status;
  ASSERT_TRUE(stub->GetStatus(&status_context, {}, &status).ok());
  EXPECT_TRUE(status.tracking());
  for (const v1::CameraStatus& camera : status.cameras())
    EXPECT_EQ(camera.silhouettes(), "background captured");
}

// A background learnt while someone walks through holds them: it is installed (the operator
// decides), and the answer says, per camera, how much of the image changed during the capture and
// how much differs from the background it replaces (what a person standing still would show).
TEST_F(EndToEndTest, ABackgroundCapturedWithSomeoneMovingInViewIsReported) {
  std::unique_ptr<MocapServer> server = startServer(walkingPersonConfig());
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  v1::CaptureBackgroundResponse response;
  const grpc::Status status = test::captureBackground(*stub, 25, response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.frames_used(), 25u);
  // Per camera: it moved during the capture, and it is not in the background replaced (the
  // scene's empty room, which the true silhouettes' session keeps for its recordings).
  ASSERT_EQ(response.warnings_size(), 4);
  for (int c = 0; c < 2; ++c) {
    const std::string camera =
        "camera " + std::to_string(c) + " (scene:" + std::to_string(c) + "): ";
    EXPECT_THAT(response.warnings(c), ::testing::HasSubstr(camera));
    EXPECT_THAT(response.warnings(c),
                ::testing::HasSubstr(" % of the image changed during the capture"));
    EXPECT_THAT(response.warnings(2 + c), ::testing::HasSubstr(camera));
    EXPECT_THAT(response.warnings(2 + c),
                ::testing::HasSubstr(" % of the image differs from the background it replaces"));
  }
}

// A client that sees the poses have gone wrong asks the tracker to find the person again; the
// hand, whose palm is fixed, cannot be found that way, and the daemon says so.
TEST_F(EndToEndTest, ReacquireFindsThePersonAgainOrSaysWhyNot) {
  {
    std::unique_ptr<MocapServer> server = startServer(walkingPersonConfig());
    ASSERT_TRUE(server);
    auto stub = test::connect(server->port());
    auto acquisitions = [&] {
      grpc::ClientContext context;
      v1::Status status;
      EXPECT_TRUE(stub->GetStatus(&context, {}, &status).ok());
      return status.acquisitions();
    };
    EXPECT_EQ(acquisitions(), 0u);  // started from the scene's true first pose
    grpc::ClientContext context;
    v1::ReacquireResponse response;
    ASSERT_TRUE(stub->Reacquire(&context, {}, &response).ok());
    // Found within the next frame sets (a generous limit, not a timing assertion).
    const auto deadline =
        std::chrono::steady_clock::now() + test::slowed(std::chrono::seconds(20));
    while (acquisitions() == 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_EQ(acquisitions(), 1u);
  }
  std::unique_ptr<MocapServer> hand = startServer(test::sceneConfig());
  ASSERT_TRUE(hand);
  auto stub = test::connect(hand->port());
  grpc::ClientContext context;
  v1::ReacquireResponse response;
  const grpc::Status refused = stub->Reacquire(&context, {}, &response);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("'hand' has no free root"));
  EXPECT_THAT(python("reacquire --server 127.0.0.1:" + std::to_string(hand->port())),
              ::testing::HasSubstr("FAILED_PRECONDITION: the body model 'hand'"));
  // Nor can it be told to start that way.
  ServerConfig acquire_hand = test::sceneConfig();
  acquire_hand.tracker.start = "acquire";
  const Expected<std::unique_ptr<MocapServer>> refused_start = MocapServer::create(acquire_hand);
  ASSERT_FALSE(refused_start.ok());
  EXPECT_THAT(refused_start.error(),
              ::testing::HasSubstr("tracker.start: acquire, but the body model 'hand'"));
}

// Speed limits are per frame: cameras at 50 Hz give the tracker frames half as far apart in time,
// so it tracks the body with half the per-frame limits of the model's 25 Hz: a configured person,
// the hand the fake scene brings, and the person fitted to a scene motion.
TEST_F(EndToEndTest, TracksWithSpeedLimitsPerFrameAtTheCamerasRate) {
  const std::string walk = MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh";
  for (const auto& [body, motion] :
       {std::pair<std::string, std::string>{"builtin:human", ""}, {"", ""}, {"", walk}}) {
    SCOPED_TRACE(body + " " + motion);
    ServerConfig config = test::sceneConfig();
    config.body_model = body;
    config.scene_motion = motion;
    for (CameraConfig& camera : config.cameras) camera.fps = 50;
    Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
    ASSERT_TRUE(server.ok()) << server.error();
    const BodyModel& tracked = server.value()->model();
    const BodyModel file =
        body.empty() && motion.empty() ? builtinHandModel() : builtinHumanModel();
    EXPECT_EQ(file.frame_rate, 25);
    EXPECT_EQ(tracked.frame_rate, 50);
    ASSERT_EQ(tracked.dofs.size(), file.dofs.size());
    for (std::size_t d = 0; d < file.dofs.size(); ++d)
      EXPECT_DOUBLE_EQ(tracked.dofs[d].max_speed, file.dofs[d].max_speed / 2) << file.dofs[d].name;
  }
}

// The body model file is read once, by the configuration check: the server tracks that model even
// if the file has changed (here: broken) since.
TEST_F(EndToEndTest, TracksTheBodyFileAsTheConfigurationReadIt) {
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "body_read_once";
  std::filesystem::create_directories(dir);
  std::filesystem::copy_file(MOCAP_SOURCE_DIR "/tracker/models/human.yaml", dir / "subject.yaml",
                             std::filesystem::copy_options::overwrite_existing);
  const ServerConfig config = parseConfig(
      "cameras:\n  - {driver: fake, width: 780, height: 580}\nbody_model: subject.yaml\n",
      "test.yaml", dir.string());
  std::ofstream(dir / "subject.yaml", std::ios::trunc) << "kind: horse\n";
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  ASSERT_TRUE(server.ok()) << server.error();
  EXPECT_EQ(server.value()->model().segments.size(), builtinHumanModel().segments.size());
  EXPECT_TRUE(server.value()->model().person);
}

// tracker.dofs: gait tracks the 17 gait DOFs of the walking person; the others hold the starting
// pose in every published pose. A body without gait DOFs (the hand) is refused naming the key.
TEST_F(EndToEndTest, TracksTheGaitDofsWhenTheConfigurationSaysSo) {
  ServerConfig config = walkingPersonConfig();
  config.tracker.filter.evaluations_per_frame = 800;
  config.tracker.dofs = "gait";
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const v1::Skeleton skeleton = skeletonOf(*stub);
  ASSERT_EQ(skeleton.dofs_size(), 31);
  std::vector<int> held;
  for (int d = 0; d < skeleton.dofs_size(); ++d)
    if (skeleton.dofs(d).min() == skeleton.dofs(d).max()) held.push_back(d);
  EXPECT_EQ(held.size(), 31u - 17u);

  grpc::ClientContext stream_context;
  auto reader = stub->StreamPoses(&stream_context, v1::StreamPosesRequest());
  v1::Pose pose;
  int received = 0;
  for (; received < 10 && reader->Read(&pose); ++received)
    for (int d : held) EXPECT_EQ(pose.dofs(d), skeleton.dofs(d).min()) << skeleton.dofs(d).name();
  stream_context.TryCancel();
  EXPECT_EQ(received, 10);
  server->shutdown();

  ServerConfig hand = test::sceneConfig();
  hand.tracker.dofs = "gait";
  Expected<std::unique_ptr<MocapServer>> refused = MocapServer::create(hand);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.error(),
              ::testing::HasSubstr("tracker.dofs: gait, but the body model 'hand'"));
}

// Live, a tracker whose refinement cannot fit in a frame period gives it up when the next frame
// set is waiting, and says how often in its status; the poses keep coming. A replay of the same
// frames, which queues every set, never gives it up (it stays repeatable).
TEST_F(EndToEndTest, ARefinementLongerThanAFrameGivesWayToTheNextSetLiveOnly) {
  const fs::path root = freshDirectory("yield");
  ServerConfig config = test::sceneConfig();
  // The hand's layers alone take 23,925 evaluations, more than a frame period on any machine
  // (about 0.2 s here), so the next set is waiting whenever the refinement starts.
  config.tracker.filter.evaluations_per_frame = 30000;
  config.tracker.filter.refine.share = 0.2;
  config.recording_directory = fs::canonical(root).string();
  {
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    auto stub = test::connect(server->port());
    grpc::ClientContext stream_context;
    auto reader = stub->StreamPoses(&stream_context, v1::StreamPosesRequest());
    v1::Pose pose;
    ASSERT_TRUE(reader->Read(&pose));  // recording starts once every camera has sent a frame
    record(*stub, "session", 3);
    int received = 1;
    for (; received < 3 && reader->Read(&pose); ++received) {
    }
    stream_context.TryCancel();
    EXPECT_EQ(received, 3);
    grpc::ClientContext context;
    v1::Status status;
    ASSERT_TRUE(stub->GetStatus(&context, {}, &status).ok());
    EXPECT_GE(status.refinements_cut(), 2u);
    EXPECT_GT(status.evaluations_per_frame(), 0);
    EXPECT_LT(status.evaluations_per_frame(), 25000);
  }
  PipelineStatus replayed;
  EXPECT_GE(replay(root / "session", &replayed).size(), 3u);
  EXPECT_EQ(replayed.refinements_cut, 0u);
  fs::remove_all(root);
}

TEST_F(EndToEndTest, ASceneMotionThatDoesNotLoadStopsTheStartUpNamingIt) {
  const fs::path dir = freshDirectory("bad_bvh");
  std::ofstream(dir / "broken.bvh") << "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n";
  ServerConfig config = test::sceneConfig();
  config.scene_motion = (dir / "broken.bvh").string();
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(server.error(), ::testing::HasSubstr("scene_motion: "));
  EXPECT_THAT(server.error(), ::testing::HasSubstr("broken.bvh"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mocap
