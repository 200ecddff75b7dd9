// The refinement's restart move: random draws of a limb's angles recover a leg far from its
// silhouette.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tests/tracker/filters/refine/refine_test_support.h"
#include "tracker/model/kinematics.h"

namespace mocap {
namespace {

using testing_support::pelvisAndLegs;
using testing_support::refineAlone;
using testing_support::silhouettes;
using testing_support::twoCameras;

// A leg swung back while the true leg is swung forward: on the way between the two the leg covers
// no more of the true leg's silhouette, so local steps do not bring it back; restarting the limb
// from random draws of its angles finds it.
TEST(FactoredFilter, RefinementRestartsRecoverALimbFarFromItsSilhouette) {
  const BodyModel model = pelvisAndLegs();
  const Rig rig = twoCameras(Eigen::Vector3d(0, 0, -0.3), -0.2);
  const double deg = M_PI / 180;
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(7), start = truth;
  truth[1] = 70 * deg;
  start[1] = -60 * deg;
  const std::vector<SilhouetteMask> masks = silhouettes(model, rig, truth);
  KinematicsData kinematics(model);
  const auto footError = [&](const Eigen::VectorXd& q) {
    forwardKinematics(model, kinematics, q);
    const Eigen::Vector3d foot = pointPositions(model, kinematics)[0];
    forwardKinematics(model, kinematics, truth);
    return (foot - pointPositions(model, kinematics)[0]).norm();
  };
  auto trackedFootError = [&](double share) {
    FilterOptions options;
    options.refine.restart_share = share;
    return footError(refineAlone(model, rig, masks, start, options));
  };
  ASSERT_GT(footError(start), 1.0);
  EXPECT_LT(trackedFootError(0.3), 0.03);  // 27 draws
  EXPECT_GT(trackedFootError(0), 0.3);
}

}  // namespace
}  // namespace mocap
