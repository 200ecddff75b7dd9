// Silhouette extraction on generated scenes (small images): the person is found, the cast shadow
// is not; adaptation follows a lighting drift but never absorbs a person standing still.
#include "tracker/vision/silhouette_extractor.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "tracker/sim/test_scene.h"

namespace mocap {
namespace {

struct Score {
  double iou = 0;             // mean over frames
  double shadow_fp = 0;       // shadow pixels called foreground / shadow pixels
  double off_body_fp = 0;     // other non-body pixels called foreground, last frame
  double left_over_right = 0; // growth of the background's left half relative to its right half
};

double leftOverRight(const cv::Mat& mean) {
  const int half = mean.cols / 2;
  const cv::Scalar left = cv::mean(mean(cv::Rect(0, 0, half, mean.rows)));
  const cv::Scalar right = cv::mean(mean(cv::Rect(half, 0, half, mean.rows)));
  return (left[0] + left[1] + left[2]) / (right[0] + right[1] + right[2]);
}

TestSceneOptions smallScene(bool color) {
  TestSceneOptions options;
  options.width = 320;
  options.height = 240;
  options.color = color;
  options.seed = 11;
  return options;
}

Score run(const TestSceneOptions& scene_options, const SilhouetteOptions& options, int frames) {
  SilhouetteTestScene scene(scene_options);
  TestSceneFrame frame;
  BackgroundLearner learner;
  for (int i = 0; i < 20; ++i) {
    scene.render(0, false, frame);
    learner.add(frame.image);
  }
  SilhouetteExtractor extractor(learner.model(), options);
  const double initial_balance = leftOverRight(extractor.background().mean);
  Score score;
  long shadow = 0, shadow_called = 0;
  for (int t = 0; t < frames; ++t) {
    scene.render(t, true, frame);
    EXPECT_TRUE(extractor.extract(frame.image)) << extractor.lastError();
    const cv::Mat& mask = extractor.foreground();
    const double both = cv::countNonZero(mask & frame.body);
    score.iou += both / cv::countNonZero(mask | frame.body) / frames;
    shadow += cv::countNonZero(frame.shadow);
    shadow_called += cv::countNonZero(mask & frame.shadow);
    const cv::Mat off_body = ~(frame.body | frame.shadow);
    score.off_body_fp = static_cast<double>(cv::countNonZero(mask & off_body)) /
                        cv::countNonZero(off_body);
    EXPECT_EQ(extractor.silhouette().total(), cv::countNonZero(mask));
  }
  score.shadow_fp = static_cast<double>(shadow_called) / std::max(1L, shadow);
  score.left_over_right = leftOverRight(extractor.background().mean) / initial_balance;
  return score;
}

TEST(SilhouetteExtractor, FindsPersonNotShadowColor) {
  const Score score = run(smallScene(true), {}, 20);
  EXPECT_GT(score.iou, 0.9);
  EXPECT_LT(score.shadow_fp, 0.05);
}

// Thresholds fixed before this test was re-enabled, from `mocap-experiment silhouette --gray
// --width 320 --height 240` on seeds 101-105 (100 frames): IoU 0.80-0.86, shadow FP 0.024-0.026;
// minus a margin. Gray is weaker than colour at this size (5x5 patches span more of the body).
TEST(SilhouetteExtractor, FindsPersonNotShadowGray) {
  const Score score = run(smallScene(false), {}, 20);
  EXPECT_GT(score.iou, 0.75);
  EXPECT_LT(score.shadow_fp, 0.05);
}

// What the gray connectivity step buys: with every patch that fits a scaled background taken as a
// shadow at once (no texture needed), the shadow is still suppressed but so is much of the person's
// smooth clothing over smooth background (seeds 101-105 at 320x240: IoU 0.53-0.64).
TEST(SilhouetteExtractor, GrayFlatPatchesAreNotShadowsByThemselves) {
  SilhouetteOptions options;
  options.shadow_texture_contrast = 0;
  const Score all_confident = run(smallScene(false), options, 20);
  EXPECT_LT(all_confident.shadow_fp, 0.05);
  EXPECT_LT(all_confident.iou, 0.75);
}

TEST(SilhouetteExtractor, WithoutShadowSuppressionTheShadowIsForeground) {
  SilhouetteOptions options;
  options.suppress_shadows = false;
  const Score score = run(smallScene(true), options, 10);
  EXPECT_GT(score.shadow_fp, 0.5);  // the scene's shadow is a real test
}

TEST(SilhouetteExtractor, AdaptationFollowsLocalDrift) {
  TestSceneOptions scene = smallScene(true);
  scene.illumination_drift = 0;
  scene.side_drift = 0.0005;  // the left half brightens 15% over 300 frames, the right does not
  SilhouetteOptions fixed;
  fixed.adaptive = false;
  EXPECT_NEAR(run(scene, fixed, 300).left_over_right, 1.0, 1e-6);
  const Score adaptive = run(scene, {}, 300);
  EXPECT_GT(adaptive.left_over_right, 1.08);  // the model followed most of the change
  EXPECT_LT(adaptive.off_body_fp, 0.01);
  EXPECT_GT(adaptive.iou, 0.85);
}

TEST(SilhouetteExtractor, GlobalGainFollowsBrightness) {
  TestSceneOptions scene = smallScene(true);
  scene.illumination_drift = 0.002;  // +40% over 200 frames
  SilhouetteOptions options;
  options.adaptive = false;  // the gain alone explains a global change
  const Score score = run(scene, options, 200);
  EXPECT_LT(score.off_body_fp, 0.03);
  EXPECT_GT(score.iou, 0.85);
  options.compensate_gain = false;
  EXPECT_GT(run(scene, options, 200).off_body_fp, 0.2);
}

TEST(SilhouetteExtractor, StandingPersonIsNotAbsorbed) {
  TestSceneOptions scene = smallScene(true);
  scene.moving = false;
  SilhouetteOptions options;
  options.adapt_rate = 0.2;  // fast adaptation makes absorption, if any, show quickly
  options.adapt_interval = 1;
  const Score score = run(scene, options, 300);
  EXPECT_GT(score.iou, 0.9);
}

TEST(SilhouetteExtractor, RegionOfInterestAndMismatch) {
  SilhouetteTestScene scene(smallScene(true));
  TestSceneFrame frame;
  scene.render(0, false, frame);
  SilhouetteOptions options;
  options.region_of_interest = cv::Rect(0, 0, 160, 240);
  SilhouetteExtractor extractor(learnBackground({frame.image}), options);
  scene.render(5, true, frame);
  ASSERT_TRUE(extractor.extract(frame.image));
  EXPECT_EQ(cv::countNonZero(extractor.foreground()(cv::Rect(160, 0, 160, 240))), 0);
  cv::Mat gray(240, 320, CV_8UC1, cv::Scalar(0));
  EXPECT_FALSE(extractor.extract(gray));
  EXPECT_NE(extractor.lastError().find("1 channel"), std::string::npos) << extractor.lastError();
}

}  // namespace
}  // namespace mocap
