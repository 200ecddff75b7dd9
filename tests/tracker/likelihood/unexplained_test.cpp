// Unexplained silhouette blobs: what the footprints leave, without the slivers, largest first.
#include "tracker/likelihood/unexplained.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace mocap {
namespace {

// A footprint covering the rectangle [x0, x1) x [y0, y1).
struct Box {
  std::vector<RowSpan> spans;
  Footprint footprint;
  Box(int x0, int y0, int x1, int y1) : spans(y1 - y0, RowSpan{int16_t(x0), int16_t(x1)}) {
    footprint = {y0, y1, x0, x1, spans.data()};
  }
};

TEST(UnexplainedBlobs, AreWhatTheFootprintsLeaveNearThemWithoutTheSlivers) {
  cv::Mat image = cv::Mat::zeros(120, 160, CV_8U);
  cv::rectangle(image, cv::Rect(40, 20, 60, 80), 255, cv::FILLED);   // a trunk
  cv::rectangle(image, cv::Rect(100, 40, 12, 10), 255, cv::FILLED);  // an arm out to the right
  cv::rectangle(image, cv::Rect(28, 104, 10, 10), 255, cv::FILLED);  // a foot apart
  cv::rectangle(image, cv::Rect(130, 50, 20, 20), 255, cv::FILLED);  // something far away
  const SilhouetteMask mask(image);
  // The trunk explained but for a 2-pixel strip along its left edge. The pose's box, grown by a
  // quarter on each side, is x 28-113, y 0-119: the far blob lies outside.
  const Box trunk(42, 20, 100, 100);
  const std::vector<UnexplainedBlob> blobs = unexplainedBlobs(mask, &trunk.footprint, 1, 100, 5);
  ASSERT_EQ(blobs.size(), 2u);
  EXPECT_EQ(blobs[0].area, 120);  // the arm, whole
  EXPECT_NEAR(blobs[0].centroid.x(), 105.5, 1e-9);
  EXPECT_NEAR(blobs[0].centroid.y(), 44.5, 1e-9);
  EXPECT_EQ(blobs[1].area, 100);  // the foot; the strip is gone
  EXPECT_NEAR(blobs[1].centroid.x(), 32.5, 1e-9);
  EXPECT_NEAR(blobs[1].centroid.y(), 108.5, 1e-9);

  // A higher floor drops the foot; without the opening the strip (160 pixels) stays.
  EXPECT_EQ(unexplainedBlobs(mask, &trunk.footprint, 1, 101, 5).size(), 1u);
  const std::vector<UnexplainedBlob> unopened = unexplainedBlobs(mask, &trunk.footprint, 1, 110, 1);
  ASSERT_EQ(unopened.size(), 2u);
  EXPECT_EQ(unopened[0].area, 160);
  EXPECT_NEAR(unopened[0].centroid.x(), 40.5, 1e-9);

  // Everything explained, or no footprint to look near: nothing.
  const Box all(0, 0, 160, 120);
  EXPECT_TRUE(unexplainedBlobs(mask, &all.footprint, 1, 1, 5).empty());
  EXPECT_TRUE(unexplainedBlobs(mask, nullptr, 0, 1, 5).empty());
  EXPECT_THROW(unexplainedBlobs(mask, &all.footprint, 1, 1, 4), std::invalid_argument);
}

}  // namespace
}  // namespace mocap
