// Edge distances near a silhouette: the edge between two limbs inside it is found, the room's
// edges away from it are not, and bad inputs are refused.
#include "tracker/likelihood/edge_map.h"

#include <stdexcept>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace mocap {
namespace {

// A grey room with a bright stripe far from the person; the person, two limbs side by side of
// different shades (x in [200, 260) and [260, 320), y in [100, 400)), lit with sensor noise.
struct Scene {
  cv::Mat image{480, 640, CV_8UC3, cv::Scalar(120, 120, 120)};
  cv::Mat silhouette = cv::Mat::zeros(480, 640, CV_8UC1);
  Scene() {
    image(cv::Rect(500, 0, 20, 480)).setTo(cv::Scalar(230, 230, 230));
    image(cv::Rect(200, 100, 60, 300)).setTo(cv::Scalar(40, 60, 150));
    image(cv::Rect(260, 100, 60, 300)).setTo(cv::Scalar(70, 90, 180));
    silhouette(cv::Rect(200, 100, 120, 300)).setTo(255);
    cv::Mat noise(image.size(), CV_16SC3);
    cv::theRNG().state = 7;
    cv::randn(noise, 0, 3);
    image.convertTo(image, CV_16SC3);
    image += noise;
    image.convertTo(image, CV_8UC3);
  }
};

TEST(EdgeMap, FindsTheEdgeBetweenLimbsInsideTheSilhouette) {
  const Scene scene;
  EdgeMapOptions options;
  const cv::Mat distance = edgeDistance(scene.image, scene.silhouette, options);
  ASSERT_EQ(distance.type(), CV_8UC1);
  ASSERT_EQ(distance.size(), scene.image.size());
  // Along the limbs' shared side (x 259-260), on every row away from the ends.
  for (int y = 120; y < 380; y += 10) {
    EXPECT_LE(std::min(distance.at<uint8_t>(y, 259), distance.at<uint8_t>(y, 260)), 1) << y;
    // Midway inside either limb, no edge near: 20 and more pixels away, clamped.
    EXPECT_EQ(distance.at<uint8_t>(y, 230), options.clamp) << y;
    EXPECT_EQ(distance.at<uint8_t>(y, 290), options.clamp) << y;
    // The silhouette's own boundary.
    EXPECT_EQ(distance.at<uint8_t>(y, 200), 0) << y;
    // Distances grow away from the shared side: 4 pixels off, 3 to 5.
    EXPECT_NEAR(distance.at<uint8_t>(y, 264), 4, 1) << y;
  }
  // The room's bright stripe is far from the person: no edge there.
  for (int y = 0; y < 480; y += 40) EXPECT_EQ(distance.at<uint8_t>(y, 500), options.clamp) << y;
}

TEST(EdgeMap, NoPersonNoEdges) {
  const Scene scene;
  const cv::Mat distance = edgeDistance(scene.image, cv::Mat::zeros(480, 640, CV_8UC1));
  EXPECT_EQ(cv::countNonZero(distance != EdgeMapOptions().clamp), 0);
}

TEST(EdgeMap, GrayImagesToo) {
  const Scene scene;
  cv::Mat gray;
  cv::cvtColor(scene.image, gray, cv::COLOR_BGR2GRAY);
  const cv::Mat distance = edgeDistance(gray, scene.silhouette);
  EXPECT_LE(std::min(distance.at<uint8_t>(250, 259), distance.at<uint8_t>(250, 260)), 1);
}

TEST(EdgeMap, RefusesMismatchedInputs) {
  const Scene scene;
  EXPECT_THROW(edgeDistance(scene.image, cv::Mat::zeros(480, 641, CV_8UC1)), std::invalid_argument);
  EXPECT_THROW(edgeDistance(scene.image, cv::Mat::zeros(480, 640, CV_8UC3)), std::invalid_argument);
  EXPECT_THROW(edgeDistance(cv::Mat::zeros(480, 640, CV_32FC1), scene.silhouette),
               std::invalid_argument);
}

}  // namespace
}  // namespace mocap
