// Silhouette extraction on generated scenes (small images): the person is found, the cast shadow
// is not; adaptation follows a lighting drift but never absorbs a person standing still. The
// vectorized extractor gives bit for bit the results of a plain reference kept here, and never
// uses OpenCV's thread pool.
#include "tracker/vision/silhouette_extractor.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/core/parallel/parallel_backend.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/tracker/vision/reference_extractor.h"
#include "tracker/sim/test_scene.h"

namespace mocap {
namespace {

using testing::ReferenceExtractor;

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

// The empty scene learned from 20 frames.
BackgroundLearner learnEmptyScene(SilhouetteTestScene& scene, TestSceneFrame& frame) {
  BackgroundLearner learner;
  for (int i = 0; i < 20; ++i) {
    scene.render(0, false, frame);
    learner.add(frame.image);
  }
  return learner;
}

Score run(const TestSceneOptions& scene_options, const SilhouetteOptions& options, int frames) {
  SilhouetteTestScene scene(scene_options);
  TestSceneFrame frame;
  const BackgroundLearner learner = learnEmptyScene(scene, frame);
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

// Thresholds from `mocap-experiment silhouette --width 320 --height 240` on seeds 101-105 (40
// frames): IoU 0.83-0.85, shadow FP 0.056-0.064, minus a margin. The narrow soft shadows of this
// small scene fail the plane fit along their rims, which the colour test alone passed (IoU
// 0.91-0.95, shadow FP 0.001); the fit is what keeps grey clothes (TrousersOfTheFloorsColour...).
TEST(SilhouetteExtractor, FindsPersonNotShadowColor) {
  const Score score = run(smallScene(true), {}, 20);
  EXPECT_GT(score.iou, 0.8);
  EXPECT_LT(score.shadow_fp, 0.08);
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

// The share of the person missed over `frames` frames of a person wearing trousers of the floor's
// own colour, darker and without its texture (grey trousers over a grey floor): they dim the floor
// and keep its colour, as a shadow does, but do not carry the tiles' grout and grain.
double trousersMissed(const SilhouetteOptions& options, int frames) {
  cv::Mat floor_colour;  // the empty scene's colour, blurred: its hue without its texture
  TestSceneOptions scene_options = smallScene(true);
  scene_options.camouflage = false;
  scene_options.person = [&floor_colour](int t, const CameraModel& camera, PersonLayer& layer) {
    const cv::Size size(camera.width, camera.height);
    layer.mask = cv::Mat::zeros(size, CV_8UC1);
    for (const int left : {125, 168})  // two legs, stepping sideways
      cv::rectangle(layer.mask, cv::Rect(left + (t % 10), 110, 26, 90), 255, cv::FILLED);
    layer.colour = cv::Mat::zeros(size, CV_8UC3);
    if (!floor_colour.empty()) cv::Mat(floor_colour * 0.6).copyTo(layer.colour, layer.mask);
  };
  SilhouetteTestScene scene(scene_options);
  TestSceneFrame frame;
  const BackgroundLearner learner = learnEmptyScene(scene, frame);
  cv::blur(learner.model().mean, floor_colour, cv::Size(31, 31));
  floor_colour.convertTo(floor_colour, CV_8UC3);
  SilhouetteExtractor extractor(learner.model(), options);
  long person = 0, missed = 0;
  for (int t = 0; t < frames; ++t) {
    scene.render(t, true, frame);
    EXPECT_TRUE(extractor.extract(frame.image)) << extractor.lastError();
    person += cv::countNonZero(frame.body);
    missed += cv::countNonZero(frame.body & ~extractor.foreground());
  }
  return static_cast<double>(missed) / static_cast<double>(person);
}

TEST(SilhouetteExtractor, TrousersOfTheFloorsColourAreNotShadow) {
  EXPECT_LT(trousersMissed({}, 10), 0.1);
  // Colour alone cannot tell them apart: with every patch that keeps the background's colour and
  // fits a scaled background taken as shadow at once, most of the legs are lost.
  SilhouetteOptions colour_only;
  colour_only.shadow_texture_sigmas = 50;
  colour_only.shadow_texture_contrast = 0;
  EXPECT_GT(trousersMissed(colour_only, 10), 0.5);
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

// The extractor adapts its own copy: the model it was given (saved as learned, or shared with
// another camera's reader) stays as it was.
TEST(SilhouetteExtractor, AdaptationLeavesTheGivenModelAsLearnt) {
  TestSceneOptions scene_options = smallScene(true);
  scene_options.side_drift = 0.001;
  SilhouetteTestScene scene(scene_options);
  TestSceneFrame frame;
  const BackgroundModel given = learnEmptyScene(scene, frame).model();
  const cv::Mat as_learnt = given.mean.clone();
  SilhouetteExtractor extractor(given, {});
  for (int t = 0; t < 100; ++t) {
    scene.render(t, true, frame);
    ASSERT_TRUE(extractor.extract(frame.image)) << extractor.lastError();
  }
  EXPECT_GT(cv::norm(extractor.background().mean, as_learnt, cv::NORM_INF), 1.0);  // it adapted
  EXPECT_EQ(cv::norm(given.mean, as_learnt, cv::NORM_INF), 0.0);
}

// At +20% the brightest tiles stay below 255. Clipped pixels (+40% here) dim the texture they
// show, fail the shadow test's plane fit and are taken as foreground.
TEST(SilhouetteExtractor, GlobalGainFollowsBrightness) {
  TestSceneOptions scene = smallScene(true);
  scene.illumination_drift = 0.001;  // +20% over 200 frames
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
  // Absorbed, the person would fade into the background within tens of frames at this rate and
  // the mean IoU tend to 0. Not absorbed: 0.80 (0.84 without adaptation; the still shadow's rim,
  // adapted into the background, then fails the plane fit).
  EXPECT_GT(run(scene, options, 300).iou, 0.75);
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

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         cv::countNonZero(cv::Mat(a != b).reshape(1)) == 0;
}

// Runs both extractors over the frames and counts the frames where anything differs; adaptation
// runs every adapt_interval.
int framesThatDiffer(const BackgroundModel& model, const std::vector<cv::Mat>& frames,
                     const SilhouetteOptions& options) {
  SilhouetteExtractor fast(model, options);
  ReferenceExtractor reference(model, options);
  int differ = 0, foreground = 0, shadow = 0;
  for (std::size_t t = 0; t < frames.size(); ++t) {
    EXPECT_TRUE(fast.extract(frames[t])) << fast.lastError();
    reference.extract(frames[t]);
    foreground += cv::countNonZero(reference.foreground());
    shadow += cv::countNonZero(reference.shadows());
    const bool same = identical(fast.foreground(), reference.foreground()) &&
                      identical(fast.shadows(), reference.shadows()) &&
                      fast.gain() == reference.gain() &&
                      identical(fast.background().mean, reference.background().mean) &&
                      identical(fast.silhouette().toMat(), reference.foreground());
    EXPECT_TRUE(same) << "frame " << t << ": foreground pixels differing "
                      << cv::countNonZero(fast.foreground() != reference.foreground());
    differ += same ? 0 : 1;
  }
  EXPECT_GT(foreground, 0);  // the comparison covers a person
  if (options.suppress_shadows) {
    EXPECT_GT(shadow, 0);  // and a shadow
  }
  return differ;
}

// The same over `count` rendered frames (a moving person, cast shadow, noise, light drift).
int framesThatDiffer(const TestSceneOptions& scene_options, const SilhouetteOptions& options,
                     int count) {
  SilhouetteTestScene scene(scene_options);
  TestSceneFrame frame;
  const BackgroundLearner learner = learnEmptyScene(scene, frame);
  std::vector<cv::Mat> frames;
  for (int t = 0; t < count; ++t) {
    scene.render(t, true, frame);
    frames.push_back(frame.image.clone());
  }
  return framesThatDiffer(learner.model(), frames, options);
}

TEST(SilhouetteExtractor, SameAsReferenceColorAndGray) {
  for (const bool color : {true, false}) {
    TestSceneOptions scene;  // 780x580, the product's frame size
    scene.color = color;
    EXPECT_EQ(framesThatDiffer(scene, {}, 17), 0) << (color ? "colour" : "gray");
  }
}

TEST(SilhouetteExtractor, SameAsReferenceWithOtherOptions) {
  SilhouetteOptions wide;
  wide.open_radius = 2;
  wide.close_radius = 3;
  wide.adapt_interval = 1;
  SilhouetteOptions region;
  region.region_of_interest = cv::Rect(37, 21, 201, 170);
  SilhouetteOptions plain;
  plain.suppress_shadows = false;
  plain.compensate_gain = false;
  plain.open_radius = 0;
  for (const bool color : {true, false})
    for (const SilhouetteOptions& options : {wide, region, plain}) {
      TestSceneOptions scene = smallScene(color);
      scene.illumination_drift = 0.004;  // the gain moves every frame
      EXPECT_EQ(framesThatDiffer(scene, options, 10), 0) << (color ? "colour" : "gray");
    }
}

// Frames of a textured wall with a flat panel, moving from frame to frame under a rising gain:
// blobs touching every border (the last 64-pixel word of a row is partial), a ring with a hole too
// big to fill, a thin line and speckle that the opening removes, and shadows (the wall darkened)
// over texture and over the flat panel. Noise sigma 2.5, as the model says.
std::pair<BackgroundModel, std::vector<cv::Mat>> blobFrames(bool color) {
  const cv::Size size(333, 150);
  cv::RNG rng(7);
  cv::Mat wall(size, CV_32FC1);
  rng.fill(wall, cv::RNG::UNIFORM, 60, 200);
  cv::GaussianBlur(wall, wall, cv::Size(0, 0), 0.8);
  wall(cv::Rect(200, 40, 100, 80)).setTo(120);
  cv::Mat mean = wall;
  if (color) cv::merge(std::vector<cv::Mat>{wall, wall * 0.8, wall * 1.1}, mean);
  BackgroundModel model{mean, cv::Mat(size, mean.type(), cv::Scalar::all(2.5))};
  std::vector<cv::Mat> frames;
  for (int t = 0; t < 12; ++t) {
    cv::Mat scene = mean.clone(), noise(size, mean.type()), frame;
    const int shift = 3 * t;
    for (const cv::Rect& shadow : {cv::Rect(150 + shift, 30, 90, 60), cv::Rect(230, 90, 60, 50)}) {
      cv::Mat darkened = scene(shadow);
      darkened *= 0.6;
    }
    const cv::Scalar person = cv::Scalar::all(30 + 10 * t);
    cv::rectangle(scene, cv::Rect(0, 20 + shift, 25, 40), person, cv::FILLED);
    cv::rectangle(scene, cv::Rect(size.width - 30, 60, 30, 50 + shift), person, cv::FILLED);
    cv::rectangle(scene, cv::Rect(100 + shift, 0, 40, 20), person, cv::FILLED);
    cv::circle(scene, cv::Point(60 + shift, size.height - 5), 20, person, cv::FILLED);
    cv::circle(scene, cv::Point(110, 80), 32, cv::Scalar::all(245), cv::FILLED);
    mean(cv::Rect(95, 65, 30, 30)).copyTo(scene(cv::Rect(95, 65, 30, 30)));  // the hole
    cv::line(scene, cv::Point(10, 140), cv::Point(300, 100 - shift), person, 1);
    for (int k = 0; k < 40; ++k)
      cv::circle(scene, cv::Point(rng.uniform(0, size.width), rng.uniform(0, size.height)), 0,
                 cv::Scalar::all(255), cv::FILLED);
    rng.fill(noise, cv::RNG::NORMAL, 0, 2.5);
    cv::Mat(scene + noise).convertTo(frame, CV_8U, 1.0 + 0.01 * t);
    frames.push_back(frame);
  }
  return {model, frames};
}

TEST(SilhouetteExtractor, SameAsReferenceWithBlobsAtTheBorders) {
  SilhouetteOptions wide;
  wide.open_radius = 2;
  wide.close_radius = 3;
  wide.adapt_interval = 3;
  SilhouetteOptions region;
  region.region_of_interest = cv::Rect(5, 3, 300, 140);
  for (const bool color : {true, false}) {
    const auto [model, frames] = blobFrames(color);
    for (const SilhouetteOptions& options : {SilhouetteOptions{}, wide, region})
      EXPECT_EQ(framesThatDiffer(model, frames, options), 0) << (color ? "colour" : "gray");
  }
}

// testRow decides most bytes from a bracket of the normalized value; bounds within a level of that
// value are the cases it must leave to the exact test. Widths below 16, with a partial last
// vector, and a frame's; scales 0 and >= 128 take the scalar path.
TEST(SilhouetteKernels, TestRowIsConvertToThenInRange) {
  cv::RNG rng(3);
  for (const int channels : {1, 3})
    for (const int cols : {5, 16, 37, 780})
      for (const float scale :
           {0.0f, 0.37f, 0.93f, 0.999f, 1.0f, 1.0371f, 1.7f, 3.3f, 127.9f, 300.0f}) {
        cv::Mat in(1, cols, CV_8UC(channels)), normalized, wide,
            below(in.size(), CV_16SC(channels)), above(in.size(), CV_16SC(channels)), lower, upper,
            expected;
        rng.fill(in, cv::RNG::UNIFORM, 0, 256);
        in.convertTo(normalized, -1, static_cast<double>(scale));
        normalized.convertTo(wide, CV_16S);
        // Mostly two levels of room (the bracket decides), a few bounds at or past the value.
        below.setTo(2);
        above.setTo(2);
        for (int i = 0; i < cols * channels / 40 + 1; ++i) {
          const int at = rng.uniform(0, cols * channels);
          below.ptr<int16_t>()[at] = static_cast<int16_t>(rng.uniform(-1, 2));
          above.ptr<int16_t>()[at] = static_cast<int16_t>(rng.uniform(-1, 2));
        }
        cv::Mat(wide - below).convertTo(lower, CV_8U);
        cv::Mat(wide + above).convertTo(upper, CV_8U);
        cv::inRange(normalized, lower, upper, expected);
        cv::Mat unchanged(1, cols, CV_8UC1);
        silhouette_kernels::testRow(in.ptr<uint8_t>(), lower.ptr<uint8_t>(), upper.ptr<uint8_t>(),
                                    cols, channels, scale, unchanged.ptr<uint8_t>());
        EXPECT_TRUE(identical(unchanged, expected))
            << channels << " channel(s), " << cols << " columns, scale " << scale;
        cv::Mat normalized_row(in.size(), in.type());
        silhouette_kernels::normalizeRow(in.ptr<uint8_t>(), cols * channels, scale,
                                         normalized_row.ptr<uint8_t>());
        EXPECT_TRUE(identical(normalized_row, normalized)) << "scale " << scale;
      }
}

// The ratio kernels normalize the frame's bytes themselves (vectors below a scale of 128, plain
// code above it and in a last partial vector): their ratios, squares and band flags are those of
// the bytes normalizeRow gives, through the plain expressions. Half the colour pixels are a dimmed
// background, so that the colour test passes as well as fails.
TEST(SilhouetteKernels, RatioRowsAreOfNormalizeRow) {
  cv::RNG rng(5);
  const silhouette_kernels::ShadowBand band{0.35f, 0.97f, 3.0f, 0.06f};
  const auto inside = [&band](float ratio) {
    return ratio >= band.min_ratio && ratio <= band.max_ratio;
  };
  for (const int cols : {5, 16, 37, 780})
    for (const float scale : {0.0f, 0.37f, 0.93f, 1.0f, 1.0371f, 3.3f, 127.9f, 300.0f}) {
      std::vector<float> ratio(cols), squared(cols);
      std::vector<uint8_t> in_band(cols);

      cv::Mat gray(1, cols, CV_8UC1), normalized(1, cols, CV_8UC1), inverse(1, cols, CV_32FC1);
      rng.fill(gray, cv::RNG::UNIFORM, 0, 256);
      rng.fill(inverse, cv::RNG::UNIFORM, 0.002, 0.02);
      silhouette_kernels::normalizeRow(gray.ptr<uint8_t>(), cols, scale, normalized.ptr<uint8_t>());
      silhouette_kernels::ratioRow(gray.ptr<uint8_t>(), scale, inverse.ptr<float>(), cols, band,
                                   ratio.data(), squared.data(), in_band.data());
      for (int x = 0; x < cols; ++x) {
        const float expected = normalized.at<uint8_t>(x) * inverse.at<float>(x);
        ASSERT_EQ(ratio[x], expected) << "gray, " << cols << " columns, scale " << scale;
        ASSERT_EQ(squared[x], expected * expected);
        ASSERT_EQ(in_band[x], inside(expected) ? 255 : 0);
      }

      cv::Mat mean(1, cols, CV_32FC3), bgr(1, cols, CV_8UC3), sigma(1, cols, CV_32FC1),
          unchanged(1, cols, CV_8UC1);
      rng.fill(mean, cv::RNG::UNIFORM, 20, 230);
      rng.fill(bgr, cv::RNG::UNIFORM, 0, 256);
      rng.fill(sigma, cv::RNG::UNIFORM, 1, 4);
      for (int x = 0; x < cols; ++x) {
        unchanged.at<uint8_t>(x) = rng.uniform(0, 4) == 0 ? 255 : 0;
        if (x % 2 || scale == 0) continue;
        const float dim = rng.uniform(0.3f, 1.0f);
        for (int c = 0; c < 3; ++c)
          bgr.at<cv::Vec3b>(x)[c] = cv::saturate_cast<uint8_t>(
              mean.at<cv::Vec3f>(x)[c] * dim / scale + rng.uniform(-2.0f, 2.0f));
      }
      cv::Mat normalized_bgr(1, cols, CV_8UC3);
      silhouette_kernels::normalizeRow(bgr.ptr<uint8_t>(), 3 * cols, scale,
                                       normalized_bgr.ptr<uint8_t>());
      std::vector<float> grouped(
          static_cast<std::size_t>(silhouette_kernels::groupedColourFloats(cols)), -1.0f);
      silhouette_kernels::groupColourRow(mean.ptr<float>(), cols, grouped.data());
      silhouette_kernels::colorRatioRow(bgr.ptr<uint8_t>(), scale, grouped.data(),
                                        sigma.ptr<float>(), unchanged.ptr<uint8_t>(), cols, band,
                                        ratio.data(), squared.data(), in_band.data());
      int kept = 0;
      for (int x = 0; x < cols; ++x) {
        const cv::Vec3b in = normalized_bgr.at<cv::Vec3b>(x);
        const cv::Vec3f mu = mean.at<cv::Vec3f>(x);
        const float b = in[0], g = in[1], r = in[2];
        const float total = mu[0] * mu[0] + mu[1] * mu[1] + mu[2] * mu[2] + 1.0f;
        for (int c = 0; c < 3; ++c)
          ASSERT_EQ(silhouette_kernels::groupedColourAt(grouped.data(), x, c), mu[c]);
        const float inverse_energy = 1.0f / total;
        ASSERT_EQ(silhouette_kernels::groupedColourAt(grouped.data(), x, 3), inverse_energy);
        const float expected = (b * mu[0] + g * mu[1] + r * mu[2]) * inverse_energy;
        // The colour test as first written (SilhouetteExtractor::keepsBackgroundColor).
        const float own = (b * mu[0] + g * mu[1] + r * mu[2]) / total;
        const float db = b - own * mu[0], dg = g - own * mu[1], dr = r - own * mu[2];
        const float tolerance =
            band.chroma_sigmas * sigma.at<float>(x) + band.chroma_ratio * own * std::sqrt(total);
        const bool keeps = db * db + dg * dg + dr * dr <= tolerance * tolerance;
        ASSERT_EQ(ratio[x], expected) << "colour, " << cols << " columns, scale " << scale;
        ASSERT_EQ(squared[x], expected * expected);
        const bool expected_band = !unchanged.at<uint8_t>(x) && inside(expected) && keeps;
        ASSERT_EQ(in_band[x], expected_band ? 255 : 0) << "column " << x << ", scale " << scale;
        kept += expected_band;
      }
      if (cols == 780 && scale > 0.5f && scale < 2) {
        EXPECT_GT(kept, 0);  // the test saw the colour test pass
      }
    }
}

// patchSums5x5 gives cv::boxFilter's unnormalized 5x5 sums bit for bit, borders included. The
// values span many binary orders of magnitude, so that a different order of the double sums would
// round differently.
TEST(SilhouetteKernels, PatchSumsAreBoxFilter) {
  cv::RNG rng(9);
  std::vector<double> row_sums;
  for (const cv::Size size : {cv::Size(5, 5), cv::Size(6, 9), cv::Size(4, 7), cv::Size(37, 23),
                              cv::Size(780, 61), cv::Size(2, 2)}) {
    cv::Mat exponent(size, CV_32FC1), src, expected, sums;
    rng.fill(exponent, cv::RNG::UNIFORM, -30.0, 30.0);
    cv::exp(exponent, src);
    cv::boxFilter(src, expected, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
    silhouette_kernels::patchSums5x5(src, sums, row_sums);
    ASSERT_EQ(sums.size(), size);
    EXPECT_TRUE(identical(sums, expected)) << size;
  }
}

// Counts OpenCV's parallel loops and runs each on the calling thread.
class CountingParallelBackend : public cv::parallel::ParallelForAPI {
 public:
  void parallel_for(int tasks, FN_parallel_for_body_cb_t body, void* data) override {
    ++calls;
    body(0, tasks, data);
  }
  int getThreadNum() const override { return 0; }
  int getNumThreads() const override { return threads_; }
  int setNumThreads(int threads) override { return std::exchange(threads_, threads); }
  const char* getName() const override { return "counting"; }

  std::atomic<int> calls{0};

 private:
  int threads_ = 4;
};

// Threads are the daemon's: extraction, adaptation included, starts no OpenCV parallel loop
// whatever cv::setNumThreads says. Last in this file, as the counting backend stays installed.
TEST(SilhouetteExtractor, NeverUsesOpenCvThreads) {
  cv::setNumThreads(4);
  const auto backend = std::make_shared<CountingParallelBackend>();
  cv::parallel::setParallelForBackend(backend);
  cv::Mat big(580, 780, CV_8UC3, cv::Scalar(1, 2, 3)), resized;
  cv::resize(big, resized, cv::Size(1560, 1160));
  ASSERT_GT(backend->calls, 0);  // the counter sees OpenCV's parallel loops
  SilhouetteOptions options;
  options.adapt_interval = 1;
  for (const bool color : {true, false}) {
    SilhouetteTestScene scene(smallScene(color));
    TestSceneFrame frame;
    std::vector<cv::Mat> frames;
    for (int t = 0; t < 6; ++t) {
      scene.render(t, t > 0, frame);
      frames.push_back(frame.image.clone());
    }
    backend->calls = 0;
    SilhouetteExtractor extractor(learnBackground({frames[0]}), options);
    for (int t = 1; t < 6; ++t) ASSERT_TRUE(extractor.extract(frames[t]));
    EXPECT_GT(cv::countNonZero(extractor.foreground()), 0);
    EXPECT_EQ(backend->calls, 0) << (color ? "colour" : "gray");
  }
}
}  // namespace
}  // namespace mocap
