// Recorder and SessionReader by image mode: lossless, compressed (JPEG) and none round-trip, each
// keeping the silhouettes a replay would extract; format 1 sessions still read.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "drivers/record/recorder.h"
#include "drivers/record/session_reader.h"
#include "drivers/record/recording_test_scene.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using test::kSceneHeight;
using test::kSceneWidth;

class RecordingModes : public ::testing::TestWithParam<ImageMode> {
 protected:
  void SetUp() override { root_ = test::freshRoot("modes"); }
  void TearDown() override { fs::remove_all(root_); }
  fs::path root_;
};

// Per set and camera, what a replay of the lossless images extracts: a fresh extractor on the
// recorded background, adapting over the frames in order.
std::vector<std::vector<cv::Mat>> replayedSilhouettes(const std::vector<FrameSet>& sets,
                                                      const BackgroundModel& background) {
  SilhouetteExtractor extractors[2] = {SilhouetteExtractor(background),
                                       SilhouetteExtractor(background)};
  std::vector<std::vector<cv::Mat>> silhouettes(sets.size());
  for (std::size_t s = 0; s < sets.size(); ++s)
    for (int c = 0; c < 2; ++c) {
      EXPECT_TRUE(extractors[c].extract(sets[s].frames[c]->image));
      silhouettes[s].push_back(extractors[c].silhouette().toMat());
    }
  return silhouettes;
}

TEST_P(RecordingModes, KeepImagesAsAskedAndTheSilhouettesAReplayExtracts) {
  const ImageMode mode = GetParam();
  RecorderOptions options;
  options.images = mode;
  Recorder recorder(root_, options);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  const auto background = test::sceneBackground();
  for (int c = 0; c < 2; ++c) recorder.writeBackground(c, 0, background);
  std::vector<FrameSet> sets;
  for (int n = 0; n < 6; ++n) {
    sets.push_back(test::sceneSet(n));
    recorder.write(sets.back());
  }
  ASSERT_TRUE(recorder.close().ok());
  ASSERT_EQ(recorder.stats().sets_written, sets.size());

  Expected<std::unique_ptr<SessionReader>> opened = SessionReader::open(recorder.sessionPath());
  ASSERT_TRUE(opened.ok()) << opened.error();
  const SessionReader& reader = *opened.value();
  EXPECT_EQ(reader.images(), mode);
  ASSERT_EQ(reader.sets().size(), sets.size());
  // No image to extract from without images: the silhouettes are the record.
  EXPECT_EQ(reader.backgrounds().size(), mode == ImageMode::kNone ? 0u : 2u);
  const auto expected = replayedSilhouettes(sets, *background);
  for (std::size_t s = 0; s < sets.size(); ++s) {
    for (int c = 0; c < 2; ++c) {
      Expected<cv::Mat> silhouette = reader.readSilhouette(s, c);
      ASSERT_TRUE(silhouette.ok()) << silhouette.error();
      ASSERT_EQ(cv::norm(silhouette.value(), expected[s][c], cv::NORM_INF), 0) << s << " " << c;
      EXPECT_GT(test::intersectionOverUnion(silhouette.value(), test::sceneSubject(s, c)), 0.9);

      Expected<Frame> frame = reader.readFrame(s, c);
      ASSERT_TRUE(frame.ok()) << frame.error();
      EXPECT_EQ(frame.value().sequence, sets[s].frames[c]->sequence);
      EXPECT_EQ(frame.value().timestamp_ns, sets[s].frames[c]->timestamp_ns);
      const cv::Mat& original = sets[s].frames[c]->image;
      ASSERT_EQ(frame.value().image.type(), original.type());
      if (mode == ImageMode::kLossless) {
        EXPECT_EQ(cv::norm(frame.value().image, original, cv::NORM_INF), 0);
      } else if (mode == ImageMode::kCompressed) {
        EXPECT_GT(cv::PSNR(frame.value().image, original), 30.0);
      } else {
        // The silhouette as an image, which a threshold turns back into it.
        cv::Mat gray, thresholded;
        cv::cvtColor(frame.value().image, gray, cv::COLOR_BGR2GRAY);
        cv::threshold(gray, thresholded, 127, 255, cv::THRESH_BINARY);
        EXPECT_EQ(cv::norm(thresholded, expected[s][c], cv::NORM_INF), 0);
      }
      // A replay of the recorded silhouettes gets the same frame with the silhouette as image.
      Expected<Frame> silhouette_frame = reader.readFrameSilhouette(s, c);
      ASSERT_TRUE(silhouette_frame.ok()) << silhouette_frame.error();
      EXPECT_EQ(silhouette_frame.value().sequence, sets[s].frames[c]->sequence);
      EXPECT_EQ(silhouette_frame.value().timestamp_ns, sets[s].frames[c]->timestamp_ns);
      ASSERT_EQ(silhouette_frame.value().image.type(), CV_8UC1);
      EXPECT_EQ(cv::norm(silhouette_frame.value().image, expected[s][c], cv::NORM_INF), 0);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Images, RecordingModes,
                         ::testing::Values(ImageMode::kLossless, ImageMode::kCompressed,
                                           ImageMode::kNone),
                         [](const auto& mode) { return std::string(imageModeName(mode.param)); });

TEST_F(RecordingModes, ThresholdsFramesWithoutABackgroundWhenAsked) {
  RecorderOptions options;
  options.images = ImageMode::kNone;
  options.threshold_without_background = true;
  Recorder recorder(root_, options);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  recorder.write(test::sceneSet(0));
  ASSERT_TRUE(recorder.close().ok());
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(recorder.sessionPath());
  ASSERT_TRUE(reader.ok()) << reader.error();
  Expected<cv::Mat> silhouette = reader.value()->readSilhouette(0, 0);
  ASSERT_TRUE(silhouette.ok()) << silhouette.error();
  // The subject is brighter than mid-grey, the room darker.
  EXPECT_GT(test::intersectionOverUnion(silhouette.value(), test::sceneSubject(0, 0)), 0.99);
}

TEST_F(RecordingModes, StoresNoSilhouetteForAFrameWithoutABackground) {
  Recorder recorder(root_);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  recorder.write(test::sceneSet(0));
  ASSERT_TRUE(recorder.close().ok());
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(recorder.sessionPath());
  ASSERT_TRUE(reader.ok()) << reader.error();
  Expected<cv::Mat> silhouette = reader.value()->readSilhouette(0, 1);
  ASSERT_TRUE(silhouette.ok()) << silhouette.error();
  EXPECT_TRUE(silhouette.value().empty());
}

// A session recorded before format 2: no `images` key, index lines without a silhouette column.
TEST_F(RecordingModes, ReadsFormatOneSessions) {
  Recorder recorder(root_);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  const FrameSet set = test::sceneSet(0);
  recorder.write(set);
  ASSERT_TRUE(recorder.close().ok());
  const fs::path session = recorder.sessionPath();
  test::downgradeToFormatOne(session);
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(session);
  ASSERT_TRUE(reader.ok()) << reader.error();
  EXPECT_EQ(reader.value()->images(), ImageMode::kLossless);
  Expected<Frame> frame = reader.value()->readFrame(0, 1);
  ASSERT_TRUE(frame.ok()) << frame.error();
  EXPECT_EQ(cv::norm(frame.value().image, set.frames[1]->image, cv::NORM_INF), 0);
}

TEST_F(RecordingModes, AnImagesModeTheFormatLacksIsNamed) {
  Recorder recorder(root_);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  ASSERT_TRUE(recorder.close().ok());
  test::rewrite(recorder.sessionPath() / kManifestFile, [](std::string text) {
    text.replace(text.find("images: lossless"), 16, "images: video");
    return text;
  });
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(recorder.sessionPath());
  ASSERT_FALSE(reader.ok());
  EXPECT_NE(reader.error().find("images: 'video' is not lossless, compressed or none"),
            std::string::npos)
      << reader.error();
}

}  // namespace
}  // namespace mocap
