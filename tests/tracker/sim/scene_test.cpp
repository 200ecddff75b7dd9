// The scene simulator draws the union of the segments' footprints.
#include "tracker/sim/scene.h"

#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/core.hpp>

namespace mocap {
namespace {

TEST(Scene, SphereSilhouetteHasTheAnalyticArea) {
  const BodyModel m = parseBodyModel(R"(
segments:
  - name: ball
    offset: [0, 0, 1]
    shape: {type: ellipsoid, radii: [0.1, 0.1, 0.1]}
)",
                                     "ball");
  const Rig rig = {CameraModel::lookAt("c", Eigen::Vector3d(0, -2, 1), Eigen::Vector3d(0, 0, 1),
                                       Eigen::Vector3d::UnitZ(), 780, 580, 1000)};
  SceneRenderer renderer(m, rig);
  const auto images = renderer.renderSilhouettes(Eigen::VectorXd(0));
  ASSERT_EQ(images.size(), 1u);
  const double r = 1000 * 0.1 / std::sqrt(4 - 0.01);
  EXPECT_NEAR(cv::countNonZero(images[0]), M_PI * r * r, 0.01 * M_PI * r * r);
  EXPECT_EQ(images[0].at<uint8_t>(290, 390), 255);
  EXPECT_EQ(images[0].at<uint8_t>(0, 0), 0);
}

TEST(Scene, OverlappingSegmentsAreDrawnOnceAndMovingAJointChangesTheImage) {
  const BodyModel m = parseBodyModel(R"(
segments:
  - name: a
    offset: [0, 0, 1]
    shape: {type: cone, axis: [1, 0, 0], length: 0.3, radius_start: 0.05, radius_end: 0.05}
  - name: b
    parent: a
    offset: [0.3, 0, 0]
    dofs: [{name: bend, axis: [0, 1, 0], min: -90, max: 90, max_speed: 10}]
    shape: {type: cone, axis: [1, 0, 0], length: 0.3, radius_start: 0.05, radius_end: 0.05}
)",
                                     "two");
  const Rig rig = {CameraModel::lookAt("c", Eigen::Vector3d(0.3, -2, 1), Eigen::Vector3d(0.3, 0, 1),
                                       Eigen::Vector3d::UnitZ(), 780, 580, 1000)};
  SceneRenderer renderer(m, rig);
  Eigen::VectorXd q(1);
  q << 0.0;
  const cv::Mat straight = renderer.renderSilhouettes(q)[0].clone();
  q << 1.2;
  const cv::Mat bent = renderer.renderSilhouettes(q)[0].clone();
  EXPECT_GT(cv::countNonZero(straight != bent), 1000);
  // Straight, the two cylinders form one 0.6 x 0.1 m bar: about 300 x 50 px, no gaps.
  EXPECT_NEAR(cv::countNonZero(straight), 300 * 50, 0.05 * 300 * 50);
}

}  // namespace
}  // namespace mocap
