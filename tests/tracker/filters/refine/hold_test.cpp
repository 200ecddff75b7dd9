// The refinement's hold move: turning a segment with its ball-joint children held undoes a pelvis
// tracked turned with its legs twisted back.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tests/tracker/filters/refine/refine_test_support.h"

namespace mocap {
namespace {

using testing_support::pelvisAndLegs;
using testing_support::refineAlone;
using testing_support::silhouettes;
using testing_support::turnedPelvis;
using testing_support::twoCameras;

// A pelvis turned the wrong way with its legs twisted back to point where the true legs point (what
// a 2-camera track of a walk ends in). Turning the pelvis alone swings the legs off their
// silhouettes, and no leg angle moves the pelvis; turning it with the legs held does.
TEST(FactoredFilter, RefinementHoldingTheChildrenUndoesATurnedPelvis) {
  const BodyModel model = pelvisAndLegs();
  const Rig rig = twoCameras(Eigen::Vector3d(0, 0, -0.3), -0.2);
  const double deg = M_PI / 180;
  Eigen::VectorXd truth(7);
  truth << 0, 35 * deg, 0, 0, -25 * deg, 0, 0;  // a stride: right leg forward, left back
  const Eigen::VectorXd start = turnedPelvis(model, truth);
  const std::vector<SilhouetteMask> masks = silhouettes(model, rig, truth);

  auto trackedYaw = [&](bool hold) {
    FilterOptions options;
    options.refine.hold = hold;
    return std::abs(refineAlone(model, rig, masks, start, options)[0]) / deg;
  };
  EXPECT_LT(trackedYaw(true), 3);
  EXPECT_GT(trackedYaw(false), 20);
}

}  // namespace
}  // namespace mocap
