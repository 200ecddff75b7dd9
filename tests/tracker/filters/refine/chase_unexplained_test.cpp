// The refinement's chase move: aiming a leg at the silhouette the pose leaves unexplained finds a
// lost leg.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tests/tracker/filters/refine/refine_test_support.h"

namespace mocap {
namespace {

using testing_support::legsWithFeet;
using testing_support::refineAlone;
using testing_support::silhouettes;
using testing_support::twoCamerasOnTheLegs;

// A leg the tracker holds straight down while the truth swings it forward: every angle between
// the two puts the leg on empty background, so no local step gets there and none is taken. The
// true leg is left unexplained in both views, and aiming the knee and the ankle at that blob puts
// the leg on it.
TEST(FactoredFilter, RefinementChasingTheUnexplainedSilhouetteFindsALostLeg) {
  const BodyModel model = legsWithFeet();
  const Rig rig = twoCamerasOnTheLegs();
  const double deg = M_PI / 180;
  Eigen::VectorXd truth(5), start(5);
  truth << 0, 80 * deg, 0, 0, 0;
  start << 0, 0, 0, 0, 0;
  const std::vector<SilhouetteMask> masks = silhouettes(model, rig, truth);
  const auto hipError = [&](bool chase) {
    FilterOptions options;
    options.refine.unexplained = chase;
    return std::abs(refineAlone(model, rig, masks, start, options)[1] - truth[1]) / deg;
  };
  EXPECT_LT(hipError(true), 3);
  EXPECT_GT(hipError(false), 40);
}

}  // namespace
}  // namespace mocap
