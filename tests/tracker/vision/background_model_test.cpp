// Background learning recovers per-pixel mean and noise; the saved model reads back identical, and
// bad files are refused with the field named.
#include "tracker/vision/background_model.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include <unistd.h>

#include <opencv2/core.hpp>

namespace mocap {
namespace {

std::vector<cv::Mat> noisyFrames(int type, int count, double sigma) {
  cv::Mat base(30, 40, type);
  cv::randu(base, 40, 200);
  cv::RNG rng(5);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < count; ++i) {
    cv::Mat noise(base.size(), CV_32FC(base.channels()));
    rng.fill(noise, cv::RNG::NORMAL, 0, sigma);
    cv::Mat frame;
    base.convertTo(frame, CV_32F);
    frame += noise;
    frame.convertTo(frame, CV_8U);
    frames.push_back(frame);
  }
  return frames;
}

TEST(BackgroundModel, LearnsMeanAndNoise) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    const auto frames = noisyFrames(type, 200, 3.0);
    const BackgroundModel model = learnBackground(frames);
    ASSERT_EQ(model.channels(), CV_MAT_CN(type));
    EXPECT_NEAR(cv::mean(model.stddev.reshape(1))[0], 3.0, 0.2);
    cv::Mat first;
    frames[0].convertTo(first, CV_32F);
    EXPECT_LT(cv::norm(model.mean, first, cv::NORM_INF), 15.0);  // within 5 sigma of one frame
  }
}

// Noise alone leaves the capture steady; a patch that changes in some frames (someone walking
// through) is counted, in gray and in colour, whichever channel changes.
TEST(BackgroundModel, UnsteadyShareCountsThePixelsThatChangedDuringTheCapture) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    std::vector<cv::Mat> frames = noisyFrames(type, 25, 3.0);
    EXPECT_EQ(unsteadyShare(learnBackground(frames)), 0.0);
    // A 10x12 patch of the 30x40 image (10 %) covered in 5 of the 25 frames, 80 levels off in
    // the last channel only.
    for (int i = 0; i < 5; ++i) {
      cv::Mat patch = frames[i](cv::Rect(5, 5, 12, 10));
      std::vector<cv::Mat> channels;
      cv::split(patch, channels);
      channels.back() += 80;
      cv::merge(channels, patch);
    }
    EXPECT_NEAR(unsteadyShare(learnBackground(frames)), 0.10, 1e-9) << type;
  }
}

// Someone standing still through a capture leaves it steady, but the background it replaces shows
// them: two captures of the empty room differ by noise alone, one with a still patch by its share.
TEST(BackgroundModel, ChangedShareCountsWhatMovedSinceTheBackgroundItReplaces) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    // One room, two captures of 25 frames with their own noise.
    const std::vector<cv::Mat> frames = noisyFrames(type, 50, 3.0);
    const std::vector<cv::Mat> first(frames.begin(), frames.begin() + 25);
    std::vector<cv::Mat> second(frames.begin() + 25, frames.end());
    const BackgroundModel before = learnBackground(first);
    EXPECT_EQ(changedShare(before, learnBackground(second), 4, 9), 0.0) << type;
    // A 10 % patch 30 levels brighter in the first channel in every frame: steady, but changed.
    for (cv::Mat& frame : second) {
      cv::Mat patch = frame(cv::Rect(5, 5, 12, 10));
      std::vector<cv::Mat> channels;
      cv::split(patch, channels);
      channels.front() += 30;
      cv::merge(channels, patch);
    }
    const BackgroundModel after = learnBackground(second);
    EXPECT_EQ(unsteadyShare(after), 0.0) << type;
    EXPECT_NEAR(changedShare(before, after, 4, 9), 0.10, 1e-9) << type;
    // The floor of the test decides for a change well above the noise: 25 levels count, 40 not.
    EXPECT_NEAR(changedShare(before, after, 4, 25), 0.10, 1e-9) << type;
    EXPECT_EQ(changedShare(before, after, 4, 40), 0.0) << type;
  }
  const BackgroundModel gray = learnBackground(noisyFrames(CV_8UC1, 5, 3.0));
  const BackgroundModel colour = learnBackground(noisyFrames(CV_8UC3, 5, 3.0));
  EXPECT_THROW(changedShare(gray, colour, 4, 9), std::invalid_argument);
}

TEST(BackgroundModel, RefusesMismatchedFrames) {
  BackgroundLearner learner;
  EXPECT_TRUE(learner.add(cv::Mat(10, 10, CV_8UC3, cv::Scalar::all(7))));
  EXPECT_FALSE(learner.add(cv::Mat(10, 11, CV_8UC3)));
  EXPECT_FALSE(learner.add(cv::Mat(10, 10, CV_8UC1)));
  EXPECT_EQ(learner.frames(), 1);
}

TEST(BackgroundModel, SaveLoadRoundTrip) {
  const BackgroundModel model = learnBackground(noisyFrames(CV_8UC3, 10, 2.0));
  const std::string path =
      (std::filesystem::temp_directory_path() / "mocap_bg_test.yml.gz").string();
  saveBackground(path, model);
  const BackgroundModel loaded = loadBackground(path);
  EXPECT_EQ(cv::norm(model.mean, loaded.mean, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(model.stddev, loaded.stddev, cv::NORM_INF), 0.0);
  std::filesystem::remove(path);
}

TEST(BackgroundModel, SaveReplacesTheFileWholeAndLeavesNoTemporary) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mocap_bg_atomic_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "camera.background.yml").string();
  saveBackground(path, learnBackground(noisyFrames(CV_8UC1, 3, 2.0)));
  const BackgroundModel colour = learnBackground(noisyFrames(CV_8UC3, 3, 2.0));
  saveBackground(path, colour);
  EXPECT_EQ(loadBackground(path).channels(), 3);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir),
                          std::filesystem::directory_iterator()),
            1);
  // A directory that does not exist: refused, naming the file, and nothing is left behind.
  const std::string nowhere = (dir / "missing" / "camera.background.yml").string();
  try {
    saveBackground(nowhere, colour);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(nowhere + ": background model not saved"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
  std::filesystem::remove_all(dir);
}

TEST(BackgroundModel, LoadNamesBadField) {
  const std::string path = (std::filesystem::temp_directory_path() / "mocap_bg_bad.yml").string();
  std::ofstream(path) << "%YAML:1.0\n---\nimage_width: 4\nimage_height: 3\nchannels: 1\n";
  try {
    loadBackground(path);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("mean: missing"), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace mocap
