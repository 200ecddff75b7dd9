// End to end, FitBody on the fake scene's person standing in the fit pose: the fitted body is the
// subject's, the clients print it, the daemon tracks with it once applied, and what cannot be
// fitted or would wait for nothing is refused.
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
using test::skeletonOf;
using test::startRecordingWhenReady;
using test::startServer;
using test::walkingPersonConfig;

// `body`'s build against the built-in human's: the summed rest lengths of `bones` (names of
// modelBoneLengths, tracker/motion/retarget.h) over the built-in human's.
double boneRatio(const BodyModel& body, const std::vector<std::string>& bones) {
  const auto total = [&](const std::vector<BoneLength>& lengths) {
    double sum = 0;
    for (const BoneLength& bone : lengths)
      for (const std::string& name : bones)
        if (bone.name == name) sum += bone.length;
    return sum;
  };
  return total(modelBoneLengths(body)) / total(modelBoneLengths(builtinHumanModel()));
}

// As a user with real cameras would: the daemon tracks the shipped human (1.75 m), the person
// (the walk's subject, much smaller) first stands in the body's fit pose, and FitBody fits the
// body to them; its answer is a body model file whose legs and arms are the subject's. One fit at
// a time; the clients print it; a fit the daemon stops during ends with UNAVAILABLE.
TEST_F(EndToEndTest, FitsTheBodyToThePersonStandingInTheFitPose) {
  ServerConfig config = walkingPersonConfig();
  config.track_subject_body = false;
  // Covers the fits below with room to spare (about 6 s here); the walk starts after.
  config.scene_fit_pose_seconds = 30;
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const BodyModel human = builtinHumanModel();
  // The tracker tracks the configured body as given, not the subject's.
  const v1::Skeleton skeleton = skeletonOf(*stub);
  ASSERT_EQ(skeleton.segments_size(), static_cast<int>(human.segments.size()));
  EXPECT_DOUBLE_EQ(skeleton.segments(0).rest_offset().z(), human.segments[0].offset.z());

  // Two at once (the default number of frame sets, 5): one fits, the other is told a fit is under
  // way.
  v1::FitBodyResponse first, second;
  grpc::Status first_status, second_status;
  std::thread other([&] { second_status = test::fitBody(*stub, 0, second); });
  first_status = test::fitBody(*stub, 0, first);
  other.join();
  ASSERT_NE(first_status.ok(), second_status.ok())
      << first_status.error_message() << " / " << second_status.error_message();
  const v1::FitBodyResponse& fitted = first_status.ok() ? first : second;
  const grpc::Status& refused = first_status.ok() ? second_status : first_status;
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("a body fit is already under way"));

  EXPECT_EQ(fitted.frame_sets_used(), 5u);
  ASSERT_EQ(fitted.proportions_size(), BodyProportions::kCount);
  for (int k = 0; k < BodyProportions::kCount; ++k)
    EXPECT_EQ(fitted.proportions(k).name(), BodyProportions::name(k));
  // The body the scene shows: the built-in human fitted to the walk's subject.
  const BodyModel subject =
      fitModelToBvh(human, loadBvh(MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh").skeleton);
  const BodyModel file = parseBodyModel(fitted.body_model_yaml(), "fitted.yaml");
  const std::vector<std::string> legs = {"l_thigh", "l_shin", "r_thigh", "r_shin"};
  const std::vector<std::string> arms = {"l_upper_arm", "l_forearm", "l_hand",
                                         "r_upper_arm", "r_forearm", "r_hand"};
  // For the record (tracker/experiments/log/service.md): the factors, and the fitted body's bones
  // against the built-in human's, the subject's in brackets.
  std::printf("fitted from %u frame sets in %.2f s, scale %.3f; factors:", fitted.frame_sets_used(),
              fitted.fit_seconds(), fitted.scale());
  for (const v1::BodyProportion& proportion : fitted.proportions())
    std::printf(" %s %.3f", proportion.name().c_str(), proportion.factor());
  std::printf("\nbones against the built-in human's, fitted (subject):");
  for (const auto& [what, bones] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"legs", legs},
           {"feet", {"l_foot", "r_foot"}},
           {"arms", arms},
           {"pelvis_neck", {"pelvis_neck"}},
           {"neck_head_top", {"neck_head_top"}},
           {"hip_width", {"hip_width"}},
           {"shoulder_width", {"shoulder_width"}}})
    std::printf(" %s %.3f (%.3f)", what.c_str(), boneRatio(file, bones), boneRatio(subject, bones));
  std::printf("\n");
  // The sets fall on whatever headings the turning subject shows when they are taken, so the
  // factors vary from run to run (the experiment's fits: legs 0.875-0.95, arms 0.71-0.76 against
  // the subject's 0.943 and 0.725). The arms tell the bodies apart: the fitted ones are the
  // subject's within 6 % of the built-in human's, which is 27.5 % off. The legs are shorter than
  // the built-in human's by more than 3 % (the subject's by 5.7 %).
  constexpr double kArmTolerance = 0.06;
  ASSERT_GT(1 - boneRatio(subject, arms), 4 * kArmTolerance);
  EXPECT_NEAR(boneRatio(file, arms), boneRatio(subject, arms), kArmTolerance);
  EXPECT_LT(boneRatio(file, legs), 0.97);
  EXPECT_LT(fitted.scale(), 0.95);
  EXPECT_GT(fitted.evaluations(), 0);
  EXPECT_GT(fitted.fit_seconds(), 0);

  // The answer is a body model file: configured as body_model (rescaled to the cameras' 25 Hz, as
  // the daemon does) it is the body the daemon tracks with those proportions, speeds included.
  EXPECT_EQ(file.frame_rate, 25);
  EXPECT_TRUE(file.person);
  ASSERT_TRUE(file.fit_pose);
  BodyProportions proportions;
  for (int k = 0; k < BodyProportions::kCount; ++k) proportions[k] = fitted.proportions(k).factor();
  const BodyModel expected = proportionedBodyModel(server->model(), proportions);
  const BodyModel loaded = atFrameRate(file, config.cameras.front().fps);
  ASSERT_EQ(loaded.dofs.size(), expected.dofs.size());
  for (std::size_t d = 0; d < loaded.dofs.size(); ++d)
    EXPECT_NEAR(loaded.dofs[d].max_speed, expected.dofs[d].max_speed, 1e-12) << loaded.dofs[d].name;
  ASSERT_EQ(loaded.segments.size(), expected.segments.size());
  for (std::size_t s = 0; s < loaded.segments.size(); ++s)
    EXPECT_LT((loaded.segments[s].offset - expected.segments[s].offset).norm(), 1e-9)
        << loaded.segments[s].name;
  // Smaller than the body it was fitted from: the pelvis stands lower.
  EXPECT_LT(loaded.segments[0].offset.z(), human.segments[0].offset.z() - 0.05);

  // mocapctl writes the file (atomically: no temporary left) and prints the figures; Python prints
  // the file with the figures as comments.
  const fs::path dir = freshDirectory("fit_body");
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  const std::string printed = mocapctl("fit-body --frames 1 --out " +
                                       (dir / "subject.yaml").string() + " --server " + address);
  EXPECT_THAT(printed, ::testing::HasSubstr("\"frame_sets_used\": 1")) << printed;
  EXPECT_THAT(printed, ::testing::HasSubstr("\"legs\": 0.")) << printed;
  EXPECT_THAT(printed, ::testing::HasSubstr("\"written\": ")) << printed;
  EXPECT_EQ(loadBodyModel((dir / "subject.yaml").string()).segments.size(), human.segments.size());
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  const std::string python_file = python("fit-body --frames 1 --server " + address);
  EXPECT_THAT(python_file, ::testing::StartsWith("# {")) << python_file;
  EXPECT_EQ(parseBodyModel(python_file, "python").segments.size(), human.segments.size());
  fs::remove_all(dir);

  // The daemon stops while a fit collects its frame sets: it says so, and stops.
  grpc::Status stopped;
  std::thread stopped_fit([&] {
    v1::FitBodyResponse response;
    stopped = test::fitBody(*stub, 250, response);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  server->shutdown();
  stopped_fit.join();
  EXPECT_EQ(stopped.error_code(), grpc::StatusCode::UNAVAILABLE) << stopped.error_message();
  EXPECT_THAT(stopped.error_message(), ::testing::HasSubstr("of 250 frame sets"));
}

// FitBody with apply: the tracker finds the subject anew with the fitted body. The skeleton and the
// poses say which body they are of, the silhouettes are explained better, and a recording started
// afterwards stores the fitted body (and the subject's, which the truth is of). A fit cannot be
// applied while a recording is open, nor a recording start while such a fit runs: a session stores
// one tracked body.
TEST_F(EndToEndTest, TracksWithTheFittedBodyOnceAFitIsApplied) {
  ServerConfig config = walkingPersonConfig();
  config.track_subject_body = false;
  config.scene_fit_pose_seconds = 60;  // the subject stands in the fit pose throughout
  const fs::path root = freshDirectory("fit_apply");
  config.recording_directory = fs::canonical(root).string();
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  auto stopRecording = [&] {
    grpc::ClientContext context;
    v1::RecordingState state;
    return stub->StopRecording(&context, {}, &state);
  };
  const auto ofVersion = [](uint32_t version) {
    return [version](const v1::Pose& pose) { return pose.body_version() == version; };
  };
  EXPECT_EQ(skeletonOf(*stub).body_version(), 0u);
  const std::vector<v1::Pose> before = readPoses(*stub, 50, ofVersion(0));
  ASSERT_EQ(before.size(), 50u);

  // While a recording is open, a fit may not change the body it stores.
  startRecordingWhenReady(*stub, "before");
  v1::FitBodyResponse response;
  const grpc::Status recording = test::fitBody(*stub, 0, response, true);
  EXPECT_EQ(recording.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(recording.error_message(), ::testing::HasSubstr("a recording is open"));
  ASSERT_TRUE(stopRecording().ok());

  // Nor may a recording start while such a fit runs.
  grpc::Status applied;
  std::thread fit([&] { applied = test::fitBody(*stub, 0, response, true); });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  grpc::ClientContext refused_context;
  v1::StartRecordingRequest request;
  request.set_path("during");
  v1::RecordingState state;
  const grpc::Status refused = stub->StartRecording(&refused_context, request, &state);
  fit.join();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("FitBody with apply"));
  ASSERT_TRUE(applied.ok()) << applied.error_message();
  EXPECT_EQ(response.body_version(), 1u);

  // The skeleton is the configured body with the fitted proportions, and says so.
  BodyProportions proportions;
  for (int k = 0; k < BodyProportions::kCount; ++k)
    proportions[k] = response.proportions(k).factor();
  const BodyModel expected = proportionedBodyModel(server->model(), proportions);
  const v1::Skeleton skeleton = skeletonOf(*stub);
  EXPECT_EQ(skeleton.body_version(), 1u);
  ASSERT_EQ(skeleton.segments_size(), static_cast<int>(expected.segments.size()));
  for (std::size_t s = 0; s < expected.segments.size(); ++s) {
    const v1::Vec3& offset = skeleton.segments(static_cast<int>(s)).rest_offset();
    EXPECT_LT(
        (Eigen::Vector3d(offset.x(), offset.y(), offset.z()) - expected.segments[s].offset).norm(),
        1e-9)
        << expected.segments[s].name;
  }

  // The fitted body explains the silhouettes of the same standing, turning subject better than
  // the built-in human (28 % longer arms, 6 % longer legs) could, over 6 s of it: within them the
  // fitted body can lose a limb for 2 s or so and find it again (silhouette fit 0.71-0.81 against
  // 0.89-0.92; tracker/experiments/log/service.md), so a 2 s window failed once in CI. The joints'
  // error is printed, not asserted: an A-pose seen by two cameras looks much the same from behind,
  // and a tracker that takes the subject facing the other way is about 400 mm off with silhouettes
  // just as well explained.
  const std::vector<v1::Pose> after = readPoses(*stub, 150, ofVersion(1));
  ASSERT_EQ(after.size(), 150u);
  const double before_fit = median(before, &v1::Pose::silhouette_fit);
  const double after_fit = median(after, &v1::Pose::silhouette_fit);
  std::printf(
      "in the fit pose, median silhouette fit / error: configured body %.3f / %.1f mm, "
      "fitted %.3f / %.1f mm\n",
      before_fit, median(before, &v1::Pose::reference_error_mm), after_fit,
      median(after, &v1::Pose::reference_error_mm));
  EXPECT_GT(after_fit, before_fit + 0.05);

  // A recording started now stores the fitted body, so a replay tracks the same one.
  startRecordingWhenReady(*stub, "after");
  ASSERT_TRUE(stopRecording().ok());
  const BodyModel stored = loadBodyModel((root / "after" / kBodyModelFile).string());
  ASSERT_EQ(stored.segments.size(), expected.segments.size());
  for (std::size_t s = 0; s < expected.segments.size(); ++s)
    EXPECT_LT((stored.segments[s].offset - expected.segments[s].offset).norm(), 1e-9);
  EXPECT_TRUE(fs::exists(root / "after" / kTruthBodyModelFile));

  // Both clients apply a fit too, each raising the version.
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  EXPECT_THAT(mocapctl("fit-body --frames 1 --apply --out " + (root / "subject.yaml").string() +
                       " --server " + address),
              ::testing::HasSubstr("\"body_version\": 2"));
  EXPECT_THAT(python("fit-body --frames 1 --apply --server " + address),
              ::testing::HasSubstr("\"body_version\": 3"));
  server->shutdown();
  fs::remove_all(root);
}

// FitBody refuses a body without a fit pose (the hand), a number of frame sets out of range, and,
// when no frame set with every camera's silhouettes comes (no background captured yet), gives up.
TEST_F(EndToEndTest, FitBodyRefusesWhatItCannotFitOrWaitsForNothing) {
  {
    std::unique_ptr<MocapServer> hand = startServer(test::sceneConfig());
    ASSERT_TRUE(hand);
    auto stub = test::connect(hand->port());
    v1::FitBodyResponse response;
    const grpc::Status no_pose = test::fitBody(*stub, 0, response);
    EXPECT_EQ(no_pose.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_THAT(no_pose.error_message(),
                ::testing::HasSubstr("the body model 'hand' has no fit_pose"));
    for (int frame_sets : {251, -1}) {
      const grpc::Status out_of_range = test::fitBody(*stub, frame_sets, response);
      EXPECT_EQ(out_of_range.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << frame_sets;
      EXPECT_THAT(out_of_range.error_message(), ::testing::HasSubstr("from 1 to 250"));
    }
    EXPECT_THAT(mocapctl("fit-body --server 127.0.0.1:" + std::to_string(hand->port())),
                ::testing::HasSubstr("FitBody: FAILED_PRECONDITION: the body model 'hand'"));
  }
  ServerConfig waiting = walkingPersonConfig();
  waiting.true_silhouettes = false;  // nothing reaches the tracker until a background is captured
  std::unique_ptr<MocapServer> server = startServer(waiting);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  v1::FitBodyResponse response;
  const grpc::Status stalled = test::fitBody(*stub, 5, response);
  EXPECT_EQ(stalled.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_THAT(stalled.error_message(), ::testing::HasSubstr("waiting for a background"));
  EXPECT_THAT(stalled.error_message(), ::testing::HasSubstr("0 of 5"));
}

}  // namespace
}  // namespace mocap
