// Forward kinematics against poses computed by hand.
#include "tracker/model/kinematics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mocap {
namespace {

// A planar two-link arm: the shoulder at (0, 0, 1) turns about Z, the elbow 0.3 m further along X
// turns about Z too; the hand point is 0.2 m along the forearm; a slider moves the forearm along X.
BodyModel planarArm() {
  return parseBodyModel(R"(
segments:
  - name: upper
    offset: [0, 0, 1]
    dofs: [{name: shoulder, axis: [0, 0, 1], min: -180, max: 180, max_speed: 10}]
    points: [{name: shoulder}]
  - name: fore
    parent: upper
    offset: [0.3, 0, 0]
    dofs:
      - {name: elbow, axis: [0, 0, 1], min: -180, max: 180, max_speed: 10}
      - {name: slide, type: translation, axis: [1, 0, 0], min: 0, max: 0.5, max_speed: 0.1}
    points: [{name: elbow}, {name: hand, at: [0.2, 0, 0]}]
)",
                        "arm");
}

TEST(Kinematics, PlanarArmMatchesHandComputedPositions) {
  const BodyModel m = planarArm();
  KinematicsData data(m);
  Eigen::VectorXd q(3);
  q << M_PI / 2, -M_PI / 2, 0.0;
  forwardKinematics(m, data, q);
  auto p = pointPositions(m, data);
  // Shoulder turned 90 degrees: the elbow lands on +Y; the elbow turns back, the forearm points +X.
  EXPECT_TRUE(p[0].isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
  EXPECT_TRUE(p[1].isApprox(Eigen::Vector3d(0, 0.3, 1), 1e-12));
  EXPECT_TRUE(p[2].isApprox(Eigen::Vector3d(0.2, 0.3, 1), 1e-12));

  q << M_PI / 6, M_PI / 3, 0.1;  // the hand at 90 degrees total, slid 0.1 m further
  forwardKinematics(m, data, q);
  p = pointPositions(m, data);
  const Eigen::Vector3d elbow(0.3 * std::cos(M_PI / 6), 0.3 * std::sin(M_PI / 6), 1);
  EXPECT_TRUE(p[1].isApprox(elbow + Eigen::Vector3d(0, 0.1, 0), 1e-12));
  EXPECT_TRUE(p[2].isApprox(elbow + Eigen::Vector3d(0, 0.3, 0), 1e-12));
}

TEST(Kinematics, ChildFrameComposesParentRotation) {
  const BodyModel m = planarArm();
  KinematicsData data(m);
  Eigen::VectorXd q(3);
  q << 0.4, 0.7, 0.0;
  forwardKinematics(m, data, q);
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(data.world[1].linear().isApprox(expected, 1e-12));
}

TEST(Kinematics, ClampToLimits) {
  const BodyModel m = planarArm();
  Eigen::VectorXd q(3);
  q << 10.0, -10.0, 3.0;
  clampToLimits(m, q);
  EXPECT_DOUBLE_EQ(q[0], M_PI);
  EXPECT_DOUBLE_EQ(q[1], -M_PI);
  EXPECT_DOUBLE_EQ(q[2], 0.5);
}

}  // namespace
}  // namespace mocap
