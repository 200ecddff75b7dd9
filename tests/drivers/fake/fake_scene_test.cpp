// The fake driver's scene cameras: pacing, ground truth, a simulated person in place of the body,
// fault knobs, enumeration, registration.
#include <chrono>
#include <cmath>
#include <optional>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "drivers/builtin_drivers.h"
#include "drivers/fake/fake_driver.h"
#include "tests/drivers/frame_collector.h"
#include "tracker/model/builtin_models.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;
constexpr auto kGenerous = std::chrono::seconds(60);

// Collects frames and events from the driver threads; each event is kept as "<camera> <message>".
class Collector : public FrameCollector {
 public:
  Collector() : FrameCollector(kGenerous, /*prefix_camera=*/true) {}
};

FakeDriverOptions smallScene(FakePacing pacing, uint64_t frame_limit) {
  FakeDriverOptions options;
  options.scene.width = 320;
  options.scene.height = 240;
  options.scene.fps = 50;
  options.scene.pacing = pacing;
  options.scene.frame_limit = frame_limit;
  options.scene.generated_frames = 60;
  return options;
}

CameraConfig sceneCamera(int index, const FakeDriverOptions& options) {
  CameraConfig config;
  config.index = index;
  config.driver = "fake";
  config.device = "scene:" + std::to_string(index);
  config.width = options.scene.width;
  config.height = options.scene.height;
  config.fps = options.scene.fps;
  return config;
}

std::unique_ptr<Camera> openCamera(FakeDriver& driver, const CameraConfig& config) {
  Expected<std::unique_ptr<Camera>> camera = driver.open(config);
  EXPECT_TRUE(camera.ok()) << camera.error();
  return camera.ok() ? std::move(camera.value()) : nullptr;
}

// The frames one camera of `driver` delivers until `count` have come (all it delivered, when its
// frame limit stops it sooner: the caller checks the count), the camera then stopped.
std::vector<Frame> firstFrames(FakeDriver& driver, const CameraConfig& config, std::size_t count) {
  Collector collector;
  std::unique_ptr<Camera> camera = openCamera(driver, config);
  if (!camera || !camera->start(collector.frameSink(), collector.eventSink()).ok()) {
    ADD_FAILURE() << config.device << " did not start";
    return {};
  }
  EXPECT_TRUE(collector.waitForFrames(count));
  camera->stop();
  return collector.frames();
}

TEST(FakeSceneCamera, RealTimeFramesHaveIncreasingSequencesAndTimestamps) {
  const FakeDriverOptions options = smallScene(FakePacing::kRealTime, 0);
  FakeDriver driver(options);
  Collector left, right;
  std::unique_ptr<Camera> cam0 = openCamera(driver, sceneCamera(0, options));
  std::unique_ptr<Camera> cam1 = openCamera(driver, sceneCamera(1, options));
  ASSERT_TRUE(cam0 && cam1);
  ASSERT_TRUE(cam0->start(left.frameSink(), left.eventSink()).ok());
  ASSERT_TRUE(cam1->start(right.frameSink(), right.eventSink()).ok());
  ASSERT_TRUE(left.waitForFrames(10));
  ASSERT_TRUE(right.waitForFrames(10));
  cam0->stop();
  cam1->stop();
  for (Collector* collector : {&left, &right}) {
    const std::vector<Frame> frames = collector->frames();
    for (std::size_t i = 0; i < frames.size(); ++i) {
      EXPECT_EQ(frames[i].image.cols, 320);
      EXPECT_EQ(frames[i].image.rows, 240);
      EXPECT_EQ(frames[i].image.type(), CV_8UC3);
      if (i == 0) continue;
      EXPECT_EQ(frames[i].sequence, frames[i - 1].sequence + 1 + frames[i].dropped_before);
      EXPECT_GT(frames[i].timestamp_ns, frames[i - 1].timestamp_ns);
    }
  }
  // Frame N of both cameras is the same simulated instant.
  const Frame a = left.frames().back();  // a copy: frames() returns a temporary
  for (const Frame& b : right.frames()) {
    if (b.sequence == a.sequence) {
      EXPECT_EQ(b.timestamp_ns, a.timestamp_ns);
    }
  }
  EXPECT_EQ(right.frames().front().camera, 1);
}

TEST(FakeSceneCamera, GroundTruthMatchesTheRenderedImage) {
  const FakeDriverOptions options = smallScene(FakePacing::kAsFastAsPossible, 8);
  FakeDriver driver(options);
  const std::vector<Frame> frames = firstFrames(driver, sceneCamera(1, options), 8);
  ASSERT_EQ(frames.size(), 8u);
  std::shared_ptr<FakeScene> scene = driver.scene().value();
  for (const Frame& frame : frames) {
    const GroundTruth truth = scene->groundTruth(frame.sequence);
    EXPECT_EQ(truth.q, scene->motion()[scene->motionFrame(frame.sequence)]);
    ASSERT_EQ(truth.silhouettes.size(), 2u);
    const cv::Mat& mask = truth.silhouettes[1];
    ASSERT_GT(cv::countNonZero(mask), 500) << "the hand should fill part of the image";
    cv::Mat difference;
    cv::absdiff(frame.image, scene->background(1), difference);
    cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
    cv::Mat outside;
    cv::bitwise_not(mask, outside);
    EXPECT_GT(cv::mean(difference, mask)[0], 40.0) << "the body must stand out of the background";
    EXPECT_LT(cv::mean(difference, outside)[0], 6.0) << "elsewhere only noise";
  }
}

// With empty_frames the room is empty at first (the background and noise alone, no truth), then
// the subject walks in at the motion's first frame.
TEST(FakeSceneCamera, AnEmptyRoomUntilTheSubjectWalksIn) {
  FakeDriverOptions options = smallScene(FakePacing::kAsFastAsPossible, 6);
  options.scene.empty_frames = 3;
  FakeDriver driver(options);
  const std::vector<Frame> frames = firstFrames(driver, sceneCamera(0, options), 6);
  ASSERT_EQ(frames.size(), 6u);
  std::shared_ptr<FakeScene> scene = driver.scene().value();
  for (const Frame& frame : frames) {
    const bool in_view = frame.sequence >= 3;
    EXPECT_EQ(scene->subjectInView(frame.sequence), in_view);
    const GroundTruth truth = scene->groundTruth(frame.sequence);
    ASSERT_EQ(truth.silhouettes.size(), 2u);
    EXPECT_EQ(cv::countNonZero(truth.silhouettes[0]) > 500, in_view) << frame.sequence;
    if (in_view) {
      EXPECT_EQ(truth.q, scene->motion()[frame.sequence - 3]);
      EXPECT_EQ(scene->truePose(frame.sequence), truth.q);
    } else {
      EXPECT_EQ(truth.q.size(), 0);
      EXPECT_EQ(scene->truePose(frame.sequence).size(), 0);
    }
    cv::Mat difference;
    cv::absdiff(frame.image, scene->background(0), difference);
    cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
    EXPECT_EQ(cv::countNonZero(difference > 40) > 500, in_view) << frame.sequence;
  }
}

// With fit_pose_frames the subject, once in view, first stands in the body model's fit pose where
// the motion starts, turning in place by up to 45 degrees either way; the truth says so; then the
// motion plays from its first frame. A body without a fit pose cannot stand in it.
TEST(FakeSceneCamera, TheSubjectStandsInTheFitPoseBeforeTheMotion) {
  FakeDriverOptions options = smallScene(FakePacing::kAsFastAsPossible, 8);
  const BodyModel human = builtinHumanModel();
  ASSERT_TRUE(human.fit_pose);
  options.scene.model = std::make_shared<const BodyModel>(human);
  options.scene.generated_frames = 20;
  options.scene.empty_frames = 2;
  options.scene.fit_pose_frames = 3;
  FakeDriver driver(options);
  const std::vector<Frame> frames = firstFrames(driver, sceneCamera(0, options), 8);
  ASSERT_EQ(frames.size(), 8u);
  std::shared_ptr<FakeScene> scene = driver.scene().value();
  const Eigen::VectorXd& first = scene->motion().front();
  Eigen::VectorXd standing = human.stancePose(*human.fit_pose);
  for (const char* kept : {"root_tx", "root_ty", "root_tz", "root_yaw"})
    standing[human.dofIndex(kept)] = first[human.dofIndex(kept)];
  ASSERT_NE(standing, first);  // the generated motion does not start in the fit pose
  const int yaw = human.dofIndex("root_yaw");
  std::optional<cv::Mat> standing_silhouette;
  std::vector<double> headings;
  for (const Frame& frame : frames) {
    SCOPED_TRACE(frame.sequence);
    const GroundTruth truth = scene->groundTruth(frame.sequence);
    EXPECT_EQ(scene->truePose(frame.sequence), truth.q);
    EXPECT_EQ(scene->inFitPose(frame.sequence), frame.sequence >= 2 && frame.sequence < 5);
    cv::Mat difference;
    cv::absdiff(frame.image, scene->background(0), difference);
    cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
    cv::Mat painted = difference > 40;
    if (frame.sequence < 2) {
      EXPECT_EQ(truth.q.size(), 0);
      EXPECT_EQ(cv::countNonZero(painted), 0);
      continue;
    }
    // The image shows the true pose: painted where its silhouette is, and little elsewhere.
    ASSERT_GT(cv::countNonZero(truth.silhouettes[0]), 100);
    cv::Mat outside;
    cv::bitwise_and(painted, ~truth.silhouettes[0], outside);
    EXPECT_LT(cv::countNonZero(outside), cv::countNonZero(truth.silhouettes[0]) / 20);
    if (frame.sequence < 5) {
      // The fit pose, turned about the motion's first heading.
      Eigen::VectorXd turned = standing;
      turned[yaw] = truth.q[yaw];
      EXPECT_EQ(truth.q, turned);
      EXPECT_LE(std::abs(truth.q[yaw] - first[yaw]), M_PI / 4 + 1e-12);
      headings.push_back(truth.q[yaw]);
      EXPECT_EQ(truth.motion_frame, 0u);
      // Turning: no two standing frames alike.
      if (standing_silhouette) {
        EXPECT_GT(cv::countNonZero(truth.silhouettes[0] != *standing_silhouette), 100);
      }
      standing_silhouette = truth.silhouettes[0];
    } else {
      EXPECT_EQ(truth.q, scene->motion()[frame.sequence - 5]);
      EXPECT_EQ(truth.motion_frame, frame.sequence - 5);
    }
  }

  ASSERT_EQ(headings.size(), 3u);
  EXPECT_NE(headings[0], headings[1]);
  EXPECT_NE(headings[1], headings[2]);

  FakeSceneOptions hand = smallScene(FakePacing::kAsFastAsPossible, 8).scene;
  hand.fit_pose_frames = 3;
  const Expected<std::shared_ptr<FakeScene>> refused = FakeScene::create(hand);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.error(), HasSubstr("the body model 'hand' has no fit_pose"));
}

// After the fit pose the subject steps out of it into the motion's first pose over
// step_out_frames, never faster than the body's speed limits (a jump there loses any tracker);
// then the motion plays from its first frame. Stepping out needs a fit pose to step out of.
TEST(FakeSceneCamera, TheSubjectStepsOutOfTheFitPoseWithinTheSpeedLimits) {
  FakeSceneOptions options = smallScene(FakePacing::kAsFastAsPossible, 0).scene;
  const BodyModel human = builtinHumanModel();
  options.model = std::make_shared<const BodyModel>(human);
  options.generated_frames = 20;
  options.empty_frames = 2;
  options.fit_pose_frames = 3;
  // The largest DOF change from one frame to the next over [first, last), in speed limits.
  const auto fastest = [&](const FakeScene& scene, uint64_t first, uint64_t last) {
    double most = 0;
    for (uint64_t f = first; f + 1 < last; ++f) {
      const Eigen::VectorXd change = scene.truePose(f + 1) - scene.truePose(f);
      for (std::size_t d = 0; d < human.dofs.size(); ++d)
        most = std::max(most,
                        std::abs(change[static_cast<Eigen::Index>(d)]) / human.dofs[d].max_speed);
    }
    return most;
  };
  const Expected<std::shared_ptr<FakeScene>> jumping = FakeScene::create(options);
  ASSERT_TRUE(jumping.ok()) << jumping.error();
  ASSERT_GT(fastest(*jumping.value(), 4, 6), 1.0);  // without: from the fit pose in one frame

  options.step_out_frames = 25;
  const Expected<std::shared_ptr<FakeScene>> created = FakeScene::create(options);
  ASSERT_TRUE(created.ok()) << created.error();
  const FakeScene& scene = *created.value();
  EXPECT_LE(fastest(scene, 4, 31), 0.5);
  for (uint64_t f = 5; f < 30; ++f) {
    EXPECT_FALSE(scene.inFitPose(f)) << f;
    EXPECT_TRUE(scene.steppingOut(f)) << f;
    EXPECT_EQ(scene.motionFrame(f), 0u) << f;
  }
  EXPECT_FALSE(scene.steppingOut(30));
  EXPECT_EQ(scene.truePose(30), scene.motion().front());
  EXPECT_EQ(scene.truePose(32), scene.motion()[2]);
  EXPECT_EQ(scene.motionFrame(32), 2u);

  options.fit_pose_frames = 0;
  const Expected<std::shared_ptr<FakeScene>> refused = FakeScene::create(options);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.error(), HasSubstr("stepping out of the fit pose needs fit pose frames"));
}

// A human scene seen by two 320x240 cameras, noiseless so a painted pixel is one the person covers;
// with `subject_seed`, the simulated person drawn from it. The motion moves every joint, the pelvis
// bobbing a few centimetres about its standing height as a person's does.
FakeSceneOptions humanScene(std::optional<uint64_t> subject_seed) {
  FakeSceneOptions options = smallScene(FakePacing::kAsFastAsPossible, 0).scene;
  const BodyModel human = builtinHumanModel();
  options.model = std::make_shared<const BodyModel>(human);
  Motion motion = generateMotion(human, 12, 1);
  const int height = human.dofIndex("root_tz");
  for (std::size_t f = 0; f < motion.size(); ++f)
    motion[f][height] = human.neutralPose()[height] + 0.03 * std::sin(0.7 * static_cast<double>(f));
  options.motion = std::make_shared<const Motion>(std::move(motion));
  options.noise_sigma = 0;
  if (subject_seed) options.subject = drawSubjectParams(*subject_seed);
  return options;
}

cv::Mat renderFrame(const FakeScene& scene, int camera, uint64_t sequence) {
  FakeRenderScratch scratch(scene.model(), scene.rig()[camera].height);
  cv::Mat image;
  scene.render(camera, sequence, scratch, image);
  return image;
}

// 255 where `image` differs from the scene's background.
cv::Mat paintedPixels(const FakeScene& scene, int camera, const cv::Mat& image) {
  cv::Mat difference;
  cv::absdiff(image, scene.background(camera), difference);
  if (difference.channels() == 3) cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
  return difference > 0;
}

double intersectionOverUnion(const cv::Mat& a, const cv::Mat& b) {
  const int both = cv::countNonZero(a & b), either = cv::countNonZero(a | b);
  return either == 0 ? 1.0 : static_cast<double>(both) / either;
}

// With a subject, the cameras and the truth show the simulated person: not the model's
// silhouette, and its joints are the subject's, which the truth body reproduces from the DOFs.
TEST(FakeSceneSubject, TheCamerasAndTheTruthShowThePersonNotTheModel) {
  for (const bool gray : {false, true}) {
    SCOPED_TRACE(gray ? "gray" : "colour");
    FakeSceneOptions options = humanScene(7);
    options.gray = gray;
    const Expected<std::shared_ptr<FakeScene>> created = FakeScene::create(options);
    ASSERT_TRUE(created.ok()) << created.error();
    const FakeScene& scene = *created.value();
    ASSERT_NE(scene.subject(), nullptr);
    const BodyModel& model = scene.model();
    SceneRenderer model_renderer(model, scene.rig());
    KinematicsData truth_kinematics(*scene.truthBody());
    for (const uint64_t sequence : {0u, 5u, 11u}) {
      SCOPED_TRACE(sequence);
      const GroundTruth truth = scene.groundTruth(sequence);
      const std::vector<cv::Mat> model_silhouettes = model_renderer.renderSilhouettes(truth.q);
      for (int c = 0; c < 2; ++c) {
        const cv::Mat& silhouette = truth.silhouettes[c];
        ASSERT_GT(cv::countNonZero(silhouette), 300);
        EXPECT_LT(intersectionOverUnion(silhouette, model_silhouettes[c]), 0.8);
        const cv::Mat painted = paintedPixels(scene, c, renderFrame(scene, c, sequence));
        EXPECT_GT(intersectionOverUnion(painted, silhouette), 0.97);
      }
      // The subject's joints, posed by the model's at the true pose.
      KinematicsData kinematics(model);
      forwardKinematics(model, kinematics, truth.q);
      const Eigen::Matrix3d pelvis_turn = pelvisTurnAt(model, kinematics);
      const SubjectJoints joints =
          scene.subject()->retarget(subjectJointsAt(model, truth.q), &pelvis_turn);
      const std::vector<Eigen::Vector3d> expected = modelPointsFromJoints(model, joints);
      ASSERT_EQ(truth.points.size(), model.points.size());
      const std::vector<Eigen::Vector3d> model_points = pointPositions(model, kinematics);
      forwardKinematics(*scene.truthBody(), truth_kinematics, truth.q);
      const std::vector<Eigen::Vector3d> carried =
          pointPositions(*scene.truthBody(), truth_kinematics);
      double off_model = 0, off_carried = 0;
      for (std::size_t p = 0; p < expected.size(); ++p) {
        EXPECT_LT((truth.points[p] - expected[p]).norm(), 1e-12) << model.points[p].name;
        off_model += (truth.points[p] - model_points[p]).norm() / expected.size();
        off_carried = std::max(off_carried, (truth.points[p] - carried[p]).norm());
      }
      EXPECT_GT(off_model, 0.02) << "the subject's joints are not the model's";
      EXPECT_LT(off_carried, 0.01) << "the truth body carries the subject's joints in the DOFs";
    }
  }
}

// Without a subject nothing changes: the model painted, its silhouettes and points the truth, the
// same pixels with the option absent or cleared.
TEST(FakeSceneSubject, WithoutOneTheModelIsPaintedAsBefore) {
  const Expected<std::shared_ptr<FakeScene>> plain = FakeScene::create(humanScene(std::nullopt));
  const Expected<std::shared_ptr<FakeScene>> person = FakeScene::create(humanScene(7));
  FakeSceneOptions cleared = humanScene(7);
  cleared.subject.reset();
  const Expected<std::shared_ptr<FakeScene>> reference = FakeScene::create(cleared);
  ASSERT_TRUE(plain.ok() && person.ok() && reference.ok());
  EXPECT_EQ(plain.value()->subject(), nullptr);
  EXPECT_EQ(plain.value()->truthBody().get(), &plain.value()->model());
  SceneRenderer model_renderer(plain.value()->model(), plain.value()->rig());
  for (const uint64_t sequence : {0u, 6u}) {
    for (int c = 0; c < 2; ++c) {
      const cv::Mat image = renderFrame(*plain.value(), c, sequence);
      EXPECT_EQ(cv::norm(image, renderFrame(*reference.value(), c, sequence), cv::NORM_INF), 0);
      EXPECT_GT(cv::norm(image, renderFrame(*person.value(), c, sequence), cv::NORM_L1), 0);
    }
    const GroundTruth truth = plain.value()->groundTruth(sequence);
    const std::vector<cv::Mat> model_silhouettes = model_renderer.renderSilhouettes(truth.q);
    for (int c = 0; c < 2; ++c)
      EXPECT_EQ(cv::countNonZero(truth.silhouettes[c] != model_silhouettes[c]), 0);
    KinematicsData kinematics(plain.value()->model());
    forwardKinematics(plain.value()->model(), kinematics, truth.q);
    EXPECT_EQ(truth.points, pointPositions(plain.value()->model(), kinematics));
  }
}

// A subject is posed by the human's joints: a body without them is refused, naming the model.
TEST(FakeSceneSubject, NeedsABodyWithTheHumansJoints) {
  FakeSceneOptions hand = smallScene(FakePacing::kAsFastAsPossible, 0).scene;
  hand.subject = drawSubjectParams(1);
  const Expected<std::shared_ptr<FakeScene>> refused = FakeScene::create(hand);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.error(), HasSubstr("a subject needs a body model with the human's joints"));
  EXPECT_THAT(refused.error(), HasSubstr("(hand)"));
}

TEST(FakeSceneCamera, AsFastAsPossibleDeliversEveryFrameOnePeriodApart) {
  const FakeDriverOptions options = smallScene(FakePacing::kAsFastAsPossible, 40);
  FakeDriver driver(options);
  const std::vector<Frame> frames = firstFrames(driver, sceneCamera(0, options), 40);
  ASSERT_EQ(frames.size(), 40u);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].sequence, i);
    EXPECT_EQ(frames[i].dropped_before, 0u);
    if (i > 0) {
      EXPECT_EQ(frames[i].timestamp_ns - frames[i - 1].timestamp_ns, 20'000'000);
    }
  }
}

// Slow motion: the same frames, each K periods apart on the clock and in its timestamp.
TEST(FakeSceneCamera, SlowMotionDeliversTheSameFramesFurtherApart) {
  FakeDriverOptions options = smallScene(FakePacing::kRealTime, 0);
  options.scene.slow_motion = 3;
  FakeDriver slow(options);
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Frame> frames = firstFrames(slow, sceneCamera(0, options), 6);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_GE(frames.size(), 6u);
  // Five intervals of 3 periods of 20 ms at least (the first frame may come at once).
  EXPECT_GE(seconds, 5 * 0.060);
  FakeDriver real_time(smallScene(FakePacing::kAsFastAsPossible, 0));
  const std::vector<Frame> reference = firstFrames(real_time, sceneCamera(0, options), 60);
  for (std::size_t i = 1; i < frames.size(); ++i) {
    const uint64_t periods = frames[i].sequence - frames[i - 1].sequence;
    EXPECT_EQ(frames[i].timestamp_ns - frames[i - 1].timestamp_ns,
              static_cast<int64_t>(periods) * 60'000'000);
    ASSERT_LT(frames[i].sequence, reference.size());
    const Frame& same = reference[frames[i].sequence];
    EXPECT_EQ(cv::norm(frames[i].image, same.image, cv::NORM_INF), 0) << frames[i].sequence;
  }
  options.scene.slow_motion = 0.5;
  EXPECT_FALSE(FakeScene::create(options.scene).ok());
}

TEST(FakeSceneCamera, GrayOutputWhenConfigured) {
  FakeDriverOptions options = smallScene(FakePacing::kAsFastAsPossible, 2);
  FakeDriver driver(options);
  CameraConfig config = sceneCamera(0, options);
  config.pixel_format = "GREY";
  const std::vector<Frame> frames = firstFrames(driver, config, 2);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames.front().image.type(), CV_8UC1);
}

TEST(FakeSceneCamera, DropsAreCountedInDroppedBefore) {
  FakeDriverOptions options = smallScene(FakePacing::kAsFastAsPossible, 200);
  options.scene.faults.drop_rate = 0.3;
  options.scene.faults.timestamp_jitter = std::chrono::milliseconds(2);
  FakeDriver driver(options);
  const std::vector<Frame> frames = firstFrames(driver, sceneCamera(0, options), 100);
  ASSERT_GE(frames.size(), 100u);
  uint64_t lost = frames.front().sequence;  // drops before the first frame
  bool jittered = false;
  for (std::size_t i = 1; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].sequence - frames[i - 1].sequence - 1, frames[i].dropped_before);
    lost += frames[i].dropped_before;
    jittered |= (frames[i].timestamp_ns - frames[i - 1].timestamp_ns) % 20'000'000 != 0;
    EXPECT_GT(frames[i].timestamp_ns, frames[i - 1].timestamp_ns);
  }
  EXPECT_GT(lost, 30u);
  EXPECT_LT(lost, 100u);
  EXPECT_TRUE(jittered);
}

TEST(FakeSceneCamera, StallStopsFramesSilentlyThenResumes) {
  FakeDriverOptions options = smallScene(FakePacing::kRealTime, 0);
  options.scene.faults.stall = {0, 5, std::chrono::milliseconds(200)};  // 10 frames at 50 Hz
  FakeDriver driver(options);
  driver.scene().value()->epochNs();  // the scene starts now: frame 5 lies ahead
  Collector collector;
  std::unique_ptr<Camera> camera = openCamera(driver, sceneCamera(0, options));
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  ASSERT_TRUE(collector.waitForFrames(1));
  const uint64_t first = collector.frames().front().sequence;
  ASSERT_LT(first, 5u) << "the machine was too slow to start before the stall";
  ASSERT_TRUE(collector.waitForFrames(5 - first + 3));
  camera->stop();
  const std::vector<Frame> frames = collector.frames();
  bool resumed = false;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_FALSE(frames[i].sequence >= 5 && frames[i].sequence < 15) << frames[i].sequence;
    if (frames[i].sequence >= 15 && !resumed) {
      resumed = true;
      EXPECT_GE(frames[i].dropped_before, 10u);
      EXPECT_EQ(frames[i].dropped_before, frames[i].sequence - frames[i - 1].sequence - 1);
    }
  }
  EXPECT_TRUE(resumed);
  EXPECT_TRUE(collector.events().empty());
}

TEST(FakeSceneCamera, DisconnectIsReportedAndFramesResume) {
  FakeDriverOptions options = smallScene(FakePacing::kAsFastAsPossible, 30);
  options.scene.faults.disconnect = {1, 10, std::chrono::milliseconds(100)};  // frames 10..14
  FakeDriver driver(options);
  Collector collector;
  std::unique_ptr<Camera> camera = openCamera(driver, sceneCamera(1, options));
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  ASSERT_TRUE(collector.waitForFrames(25));
  ASSERT_TRUE(collector.waitForEvents(2));
  camera->stop();
  const std::vector<std::string> events = collector.events();
  EXPECT_THAT(events[0], HasSubstr("1 scene:1: camera disconnected"));
  EXPECT_THAT(events[1], HasSubstr("1 scene:1: camera reconnected"));
  const std::vector<Frame> frames = collector.frames();
  ASSERT_EQ(frames.size(), 25u);
  EXPECT_EQ(frames[10].sequence, 15u);
  EXPECT_EQ(frames[10].dropped_before, 5u);
  EXPECT_EQ(frames.back().sequence, 29u);
}

TEST(FakeSceneCamera, StopReturnsPromptlyWhileWaitingForASlowFrame) {
  FakeDriverOptions options = smallScene(FakePacing::kRealTime, 0);
  options.scene.fps = 0.1;  // one frame every ten seconds
  FakeDriver driver(options);
  CameraConfig config = sceneCamera(0, options);
  Collector collector;
  std::unique_ptr<Camera> camera = openCamera(driver, config);
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  ASSERT_TRUE(collector.waitForFrames(1));  // frame 0 comes at once
  camera->stop();                           // while waiting ten seconds for frame 1: wakes at once
  EXPECT_EQ(collector.frames().size(), 1u);
}

TEST(FakeDriver, EnumeratesOnlyTheSceneCameras) {
  FakeDriver driver(smallScene(FakePacing::kRealTime, 0));
  const std::vector<CameraInfo> cameras = driver.enumerate();
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0].id, "scene:0");
  EXPECT_EQ(cameras[1].id, "scene:1");
  EXPECT_EQ(cameras[1].modes.front().width, 320);
  EXPECT_EQ(cameras[1].modes.front().fps, 50);
}

TEST(FakeDriver, BadConfigsAreNamed) {
  const FakeDriverOptions options = smallScene(FakePacing::kRealTime, 0);
  FakeDriver driver(options);
  CameraConfig config = sceneCamera(0, options);
  config.device = "scene:7";
  EXPECT_THAT(driver.open(config).error(), HasSubstr("cameras 0..1"));
  config.device = "webcam";
  EXPECT_THAT(driver.open(config).error(), HasSubstr("not scene:<camera index>"));
  config = sceneCamera(0, options);
  config.width = 640;
  EXPECT_THAT(driver.open(config).error(), HasSubstr("configured 640x240"));
  config = sceneCamera(0, options);
  config.fps = 30;
  EXPECT_THAT(driver.open(config).error(), HasSubstr("fps"));
  config = sceneCamera(0, options);
  config.device = "replay:/nonexistent/session:0";
  EXPECT_THAT(driver.open(config).error(), HasSubstr("/nonexistent/session/manifest.yaml"));
}

TEST(FakeDriver, DefaultRigsFitTheModel) {
  // A person walking 3 m along x: the lab rig stands around the middle of the path, and the pelvis
  // stays in view of both cameras all along it.
  const BodyModel human = builtinHumanModel();
  Motion walk;
  for (int f = 0; f <= 30; ++f) {
    Eigen::VectorXd q = human.neutralPose();
    q[human.dofIndex("root_tx")] += 0.1 * f;
    walk.push_back(q);
  }
  const Rig lab = defaultFakeRig(human, walk, 2, 780, 580);
  ASSERT_EQ(lab.size(), 2u);
  KinematicsData kin(human);
  const int pelvis = human.pointIndex("pelvis");
  Eigen::Vector2d middle = Eigen::Vector2d::Zero();
  for (const Eigen::VectorXd& q : walk) {
    forwardKinematics(human, kin, q);
    const Eigen::Vector3d p = kin.world[human.points[pelvis].segment] * human.points[pelvis].local;
    middle += p.head<2>() / static_cast<double>(walk.size());
    for (const CameraModel& camera : lab) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.project(p, pixel));
      EXPECT_GT(pixel.x(), 0);
      EXPECT_LT(pixel.x(), 780);
    }
  }
  EXPECT_GE((lab[0].center().head<2>() - middle).norm(), 4.0);
  // A hand-sized model gets the hand experiment's rig.
  const BodyModel hand = builtinHandModel();
  const Rig close = defaultFakeRig(hand, generateMotion(hand, 2, 1), 3, 780, 580);
  EXPECT_EQ(close.size(), 3u);
  EXPECT_LT(close[0].center().norm(), 1.0);
}

TEST(FakeDriver, IsRegisteredAsFake) {
  DriverRegistry registry;
  registerBuiltinDrivers(registry);
  const std::vector<std::string> names = registry.names();
  EXPECT_NE(std::find(names.begin(), names.end(), "fake"), names.end());
  EXPECT_EQ(registry.create("fake")->name(), "fake");
}

}  // namespace
}  // namespace mocap
