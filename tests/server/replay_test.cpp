// End to end, replay of recorded sessions: identical poses every run, tracked with the body and
// settings the session was recorded with, the error measured on the subject's body, silhouettes
// extracted against the session's backgrounds, or the recorded silhouettes tracked alike.
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
#include "drivers/record/recording_test_scene.h"
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
using test::readPoses;
using test::record;
using test::replay;
using test::startRecordingWhenReady;
using test::startServer;
using test::waitForRecordedSets;
using test::walkingPersonConfig;

// Per camera and frame (its camera sequence), the silhouettes a pipeline extracted.
class SilhouetteLog {
 public:
  Pipeline::MaskObserver observer() {
    return [this](const FrameSet& set, const std::vector<SilhouetteMask>& masks) {
      std::lock_guard lock(mutex_);
      for (std::size_t c = 0; c < set.frames.size() && c < masks.size(); ++c)
        if (set.frames[c]) masks_[{c, set.frames[c]->sequence}] = masks[c].toMat();
    };
  }
  const cv::Mat* find(std::size_t camera, uint64_t sequence) const {
    std::lock_guard lock(mutex_);
    const auto found = masks_.find({camera, sequence});
    return found == masks_.end() ? nullptr : &found->second;
  }
  std::size_t size() const {
    std::lock_guard lock(mutex_);
    return masks_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::pair<std::size_t, uint64_t>, cv::Mat> masks_;
};

double intersectionOverUnion(const cv::Mat& a, const cv::Mat& b) {
  const double both = cv::countNonZero(a & b), either = cv::countNonZero(a | b);
  return either == 0 ? 1.0 : both / either;
}

// The median over a recorded session's frames of the agreement (intersection over union) of two
// pipelines' silhouettes of the same frame.
double medianAgreement(const fs::path& session, const SilhouetteLog& a, const SilhouetteLog& b) {
  auto reader = SessionReader::open(session);
  EXPECT_TRUE(reader.ok()) << reader.error();
  std::vector<double> agreement;
  if (!reader.ok()) return 0;
  for (const SessionSet& set : reader.value()->sets()) {
    for (std::size_t c = 0; c < set.frames.size(); ++c) {
      if (!set.frames[c]) continue;
      const cv::Mat* mask_a = a.find(c, set.frames[c]->camera_sequence);
      const cv::Mat* mask_b = b.find(c, set.frames[c]->camera_sequence);
      EXPECT_TRUE(mask_a && mask_b)
          << "camera " << c << " frame " << set.frames[c]->camera_sequence;
      if (mask_a && mask_b) agreement.push_back(intersectionOverUnion(*mask_a, *mask_b));
    }
  }
  return median(std::move(agreement));  // NaN, failing every bar, if no frame was compared
}

// Two replays' poses are the same, frame by frame, to the bit.
void expectSamePoses(const std::vector<std::pair<uint64_t, std::vector<double>>>& a,
                     const std::vector<std::pair<uint64_t, std::vector<double>>>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].first, b[i].first) << "pose " << i;
    ASSERT_EQ(a[i].second, b[i].second) << "pose " << i;
  }
}

// Also: a session tracked on the scene's true silhouettes stores the empty scene as each camera's
// background, so its replay, which has no truth, extracts silhouettes close to the truth.
TEST_F(EndToEndTest, ReplayGivesIdenticalPosesEveryRun) {
  const fs::path root = freshDirectory("replay");
  SilhouetteLog truth;
  {
    ServerConfig config = test::sceneConfig();
    config.recording_directory = fs::canonical(root).string();
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    server->pipeline().setMaskObserver(truth.observer());
    auto stub = test::connect(server->port());
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    record(*stub, "session", 100);
  }
  SilhouetteLog extracted;
  PipelineStatus status;
  const auto first = replay(root / "session", &status, extracted.observer());
  EXPECT_EQ(status.cameras[0].silhouettes,
            "background recorded in the session (cam0/background_000000.yml)");
  const double agreement = medianAgreement(root / "session", truth, extracted);
  std::printf("replayed against true silhouettes, IoU median %.4f\n", agreement);
  EXPECT_GE(agreement, 0.9);
  const auto second = replay(root / "session");
  EXPECT_GE(first.size(), 100u);
  expectSamePoses(first, second);
  fs::remove_all(root);
}

TEST_F(EndToEndTest, ReplayTracksTheBodyAndSettingsTheSessionWasRecordedWith) {
  const fs::path root = freshDirectory("replay_body");
  {
    ServerConfig config = walkingPersonConfig();
    config.tracker.filter.evaluations_per_frame =
        600;  // not the replay configuration's 375, nor the people's 2000
    config.tracker.challenge_every = 0;  // not the people's either: the last set has one track
    config.recording_directory = fs::canonical(root).string();
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    auto stub = test::connect(server->port());
    {  // recording starts once every camera has sent a frame: wait for the first pose
      grpc::ClientContext context;
      v1::Pose pose;
      ASSERT_TRUE(stub->StreamPoses(&context, v1::StreamPosesRequest())->Read(&pose));
      context.TryCancel();
    }
    // More sets than the replay's acquisition trial (its hypotheses are tracked for 10 frames,
    // each spending the budget): the last frame is tracked by the one kept.
    record(*stub, "session", 15);
  }
  // The replay's configuration names no body and no tracker keys: the session's own body (31
  // DOFs) is tracked, not the built-in hand (15), with the session's settings.
  PipelineStatus status;
  std::vector<double> errors;
  const auto poses = replay(root / "session", &status, {}, &errors);
  ASSERT_FALSE(poses.empty());
  for (const auto& [sequence, dofs] : poses) ASSERT_EQ(dofs.size(), 31u) << "frame " << sequence;
  EXPECT_EQ(status.evaluations_per_frame, 600 + 1);  // and the fit of the estimate
  // The session stores the scene's truth, so every replayed pose has its error against it: the
  // person found and tracked on silhouettes extracted against the stored empty room.
  ASSERT_EQ(errors.size(), poses.size());
  const double error = median(errors);
  std::printf("replayed poses against the recorded truth: median %.1f mm over %zu\n", error,
              errors.size());
  EXPECT_LT(error, 100.0);
  fs::remove_all(root);
}

// A session of a subject tracked with a body not its own (track_subject_body: false) stores the
// subject's body beside the tracked one, so its replay measures each pose against the subject's
// joints, as the live daemon did, and not against the truth's DOFs on the tracked body.
TEST_F(EndToEndTest, ReplayMeasuresTheErrorOnTheSubjectsBody) {
  const fs::path root = freshDirectory("replay_subject");
  {
    ServerConfig config = walkingPersonConfig();
    config.track_subject_body = false;
    config.recording_directory = fs::canonical(root).string();
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    auto stub = test::connect(server->port());
    ASSERT_EQ(readPoses(*stub, 1).size(), 1u);
    record(*stub, "session", 15);
  }
  Expected<std::unique_ptr<SessionReader>> session = SessionReader::open(root / "session");
  ASSERT_TRUE(session.ok()) << session.error();
  const BodyModel* tracked = session.value()->bodyModel();
  const BodyModel* subject = session.value()->truthBodyModel();
  ASSERT_TRUE(tracked && subject && subject != tracked);
  std::vector<Eigen::VectorXd> truths;
  for (const SessionSet& set : session.value()->sets())
    for (const std::optional<IndexRecord>& frame : set.frames)
      if (const Eigen::VectorXd* truth =
              frame ? session.value()->truth(frame->camera_sequence) : nullptr)
        truths.push_back(*truth);
  ASSERT_FALSE(truths.empty());

  std::vector<Pose> poses;
  replay(root / "session", nullptr, {}, nullptr, &poses);
  ASSERT_FALSE(poses.empty());
  // The mean distance of a pose's joints from a truth's placed on `body`, in millimetres; the
  // reported error must be that of some frame's truth on the subject's body, and of none on the
  // tracked body (whose legs and arms are longer). Both to the same precision: over dozens of
  // truths, one on the tracked body can come within a millimetre of the reported error by chance,
  // never within a micrometre; one used by mistake would match to rounding.
  const auto nearestError = [&](const BodyModel& body, const Pose& pose) {
    KinematicsData kinematics(body);
    double nearest = INFINITY;
    for (const Eigen::VectorXd& truth : truths) {
      forwardKinematics(body, kinematics, truth);
      const std::vector<Eigen::Vector3d> joints = pointPositions(body, kinematics);
      double sum = 0;
      for (std::size_t p = 0; p < joints.size(); ++p) sum += (joints[p] - pose.points[p]).norm();
      nearest = std::min(nearest, std::abs(1000 * sum / joints.size() - *pose.reference_error_mm));
    }
    return nearest;
  };
  for (const Pose& pose : poses) {
    ASSERT_TRUE(pose.reference_error_mm) << "frame " << pose.frame_sequence;
    EXPECT_LT(nearestError(*subject, pose), 1e-6) << "frame " << pose.frame_sequence;
    EXPECT_GT(nearestError(*tracked, pose), 1e-3) << "frame " << pose.frame_sequence;
  }
  fs::remove_all(root);
}

// A session keeps the backgrounds its silhouettes were extracted against, the one in use when the
// recording started and one captured during it, so a replay extracts the same silhouettes from the
// recorded images instead of thresholding them.
TEST_F(EndToEndTest, ReplayExtractsSilhouettesAgainstTheSessionsBackgrounds) {
  const fs::path root = freshDirectory("replay_backgrounds");
  SilhouetteLog live;
  {
    ServerConfig config = test::sceneConfig();
    config.true_silhouettes = false;
    config.recording_directory = fs::canonical(root).string();
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    server->pipeline().setMaskObserver(live.observer());
    auto stub = test::connect(server->port());
    v1::CaptureBackgroundResponse response;
    ASSERT_TRUE(test::captureBackground(*stub, 10, response).ok());
    ASSERT_NO_FATAL_FAILURE(startRecordingWhenReady(*stub, "session"));
    ASSERT_NO_FATAL_FAILURE(waitForRecordedSets(*stub, 10));
    ASSERT_TRUE(test::captureBackground(*stub, 10, response).ok());
    ASSERT_NO_FATAL_FAILURE(waitForRecordedSets(*stub, 40));
    grpc::ClientContext context;
    v1::RecordingState state;
    ASSERT_TRUE(stub->StopRecording(&context, {}, &state).ok());
    server->shutdown();
  }
  // Per camera: the background in use at the start, from its first frame, and the one captured
  // during the recording, from a later frame.
  std::ifstream lines(root / "session" / kBackgroundsFile);
  std::string line;
  std::getline(lines, line);
  EXPECT_EQ(line, kBackgroundsHeader);
  std::vector<BackgroundRecord> records;
  while (std::getline(lines, line)) {
    Expected<BackgroundRecord> record = parseBackgroundLine(line, 2);
    ASSERT_TRUE(record.ok()) << line << ": " << record.error();
    records.push_back(record.value());
  }
  ASSERT_EQ(records.size(), 4u);
  for (int c = 0; c < 2; ++c) {
    std::vector<uint64_t> from;
    for (const BackgroundRecord& record : records)
      if (record.camera == c) from.push_back(record.from_sequence);
    ASSERT_EQ(from.size(), 2u) << "camera " << c;
    EXPECT_EQ(from[0], 0u);
    EXPECT_GT(from[1], 0u);
  }

  SilhouetteLog replayed;
  PipelineStatus status;
  replay(root / "session", &status, replayed.observer());
  ASSERT_GE(replayed.size(), 80u);  // 40 sets of 2 cameras at the least
  for (std::size_t c = 0; c < 2; ++c) {
    EXPECT_THAT(status.cameras[c].silhouettes,
                ::testing::StartsWith("background recorded in the session (cam" +
                                      std::to_string(c) + "/background_0"));
    EXPECT_THAT(status.cameras[c].silhouettes, ::testing::Not(::testing::HasSubstr("_000000")));
  }
  // Live silhouettes came from extractors that had adapted since their capture, the replayed ones
  // from the model as captured: the same up to pixels at the threshold.
  const double agreement = medianAgreement(root / "session", live, replayed);
  std::printf("replayed against live silhouettes, IoU median %.4f\n", agreement);
  EXPECT_GE(agreement, 0.98);

  // The silhouettes the session recorded are those a replay extracts, so tracking them instead
  // (no image decoded) gives the same poses.
  const auto extracted_poses = replay(root / "session");
  PipelineStatus recorded_status;
  const auto recorded_poses = replay(root / "session", &recorded_status, {}, nullptr, nullptr,
                                     /*recorded_silhouettes=*/true);
  EXPECT_EQ(recorded_status.cameras[0].silhouettes, "recorded in the session");
  ASSERT_GE(extracted_poses.size(), 40u);
  expectSamePoses(recorded_poses, extracted_poses);
  fs::remove_all(root);
}

// A replay of the recorded silhouettes has no images to record, and a session of format 1 stores
// no silhouettes: both refused, naming why.
TEST_F(EndToEndTest, ReplayOfRecordedSilhouettesRefusesWhatItCannotDo) {
  const fs::path root = freshDirectory("replay_recorded_refusals");
  Recorder recorder(root);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  recorder.write(test::sceneSet(0));
  ASSERT_TRUE(recorder.close().ok());
  ServerConfig config = test::sceneConfig();
  config.replay_directory = recorder.sessionPath().string();
  config.recording_directory = fs::canonical(root).string();
  config.recorded_silhouettes = true;
  {
    Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
    ASSERT_TRUE(server.ok()) << server.error();
    const RecordingResult refused = server.value()->pipeline().startRecording("again");
    EXPECT_EQ(refused.error, RecordingError::kNotConfigured);
    EXPECT_THAT(refused.message, ::testing::HasSubstr("no frames to record"));
    EXPECT_FALSE(fs::exists(root / "again"));
  }
  test::downgradeToFormatOne(recorder.sessionPath());
  const Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(server.error(), ::testing::HasSubstr(config.replay_directory +
                                                   " stores no silhouettes (a format 1 session"));
  config.recorded_silhouettes = false;  // its images are still replayed
  EXPECT_TRUE(MocapServer::create(config).ok());
  fs::remove_all(root);
}

}  // namespace
}  // namespace mocap
