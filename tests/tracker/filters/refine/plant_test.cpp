// The refinement's plant move: a pelvis step with the feet planted follows a squat.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tests/tracker/filters/refine/refine_test_support.h"
#include "tracker/model/kinematics.h"

namespace mocap {
namespace {

using testing_support::legsWithFeet;
using testing_support::silhouettes;
using testing_support::twoCameras;

// A squat: the pelvis 20 cm lower than the tracker holds it, hips and knees bent so the feet stand
// where they stood. With big feet under a small pelvis, a pelvis step alone pushes the feet
// through the floor and a leg angle alone lifts a foot off its silhouette, so single steps go down
// slowly (5.9 cm short after this frame, 1.8 cm after five); a pelvis step with the feet planted
// goes straight down.
TEST(FactoredFilter, RefinementPlantingTheFeetFollowsASquat) {
  const BodyModel model = legsWithFeet();
  const Rig rig = twoCameras(Eigen::Vector3d(0, 0, 0.5), 0.6);
  // Equal thigh and shin: the foot stays under the hip with the knee bent twice the hip.
  const double drop = 0.2, hip = std::acos(1 - drop / (2 * 0.42));
  Eigen::VectorXd truth(5), start = Eigen::VectorXd::Zero(5);
  truth << -drop, hip, 2 * hip, hip, 2 * hip;
  KinematicsData at_truth(model), at_start(model);
  forwardKinematics(model, at_truth, truth);
  forwardKinematics(model, at_start, start);
  const int r_foot = model.segmentIndex("r_foot");
  ASSERT_LT((at_truth.world[r_foot].translation() - at_start.world[r_foot].translation()).norm(),
            1e-9);
  const std::vector<SilhouetteMask> masks = silhouettes(model, rig, truth);

  // One frame, the refinement taking nearly all of 400 evaluations.
  auto heightError = [&](bool plant) {
    WorkerPool pool(1);
    FilterOptions options;
    options.evaluations_per_frame = 400;
    options.refine.share = 0.95;
    options.injection.share = 0;
    options.refine.plant = plant;
    auto filter = makeFilter("factored", model, rig, options, pool);
    filter->reset(start);
    return std::abs(filter->step(masks).q[0] - truth[0]);
  };
  EXPECT_LT(heightError(true), 0.01);
  EXPECT_GT(heightError(false), 0.03);
}

}  // namespace
}  // namespace mocap
