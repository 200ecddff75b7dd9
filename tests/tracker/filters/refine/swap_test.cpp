// The refinement's swap move: exchanging the legs' angles (or only the knees') undoes a stride
// tracked the wrong way round, and a body without two feet is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/tracker/filters/refine/refine_test_support.h"

namespace mocap {
namespace {

using testing_support::legsWithFeet;
using testing_support::pelvisAndLegs;
using testing_support::refineAlone;
using testing_support::silhouettes;
using testing_support::twoCamerasOnTheLegs;

// A stride tracked the wrong way round: the right leg back where the left one is, and the other
// way round. Swinging one leg through to its side leaves both legs on one silhouette leg
// half-way, so local steps stay put; exchanging the legs' angles gets there at once.
TEST(FactoredFilter, RefinementSwappingTheLegsUndoesAStrideTrackedTheWrongWayRound) {
  const BodyModel model = legsWithFeet();
  const Rig rig = twoCamerasOnTheLegs();
  const double deg = M_PI / 180;
  Eigen::VectorXd truth(5), start(5);
  // Pelvis height, then the right hip and knee, then the left's.
  truth << 0, 30 * deg, 20 * deg, -20 * deg, 40 * deg;
  start << 0, truth[3], truth[4], truth[1], truth[2];
  const std::vector<SilhouetteMask> masks = silhouettes(model, rig, truth);
  const auto worstAngleError = [&](bool swap) {
    FilterOptions options;
    options.refine.swap.enabled = swap;
    const Eigen::VectorXd angles = refineAlone(model, rig, masks, start, options).tail(4);
    return (angles - truth.tail(4)).cwiseAbs().maxCoeff() / deg;
  };
  EXPECT_LT(worstAngleError(true), 2);
  EXPECT_GT(worstAngleError(false), 20);

  // The hips right and the knees the wrong way round: exchanging only the knees gets there,
  // exchanging the whole legs (which puts the hips wrong) does not.
  Eigen::VectorXd bent(5), knees_crossed(5);
  bent << 0, 40 * deg, 10 * deg, 0, 90 * deg;
  knees_crossed << 0, bent[1], bent[4], bent[3], bent[2];
  const std::vector<SilhouetteMask> bent_masks = silhouettes(model, rig, bent);
  const auto kneeError = [&](bool knees_only) {
    FilterOptions options;
    options.refine.swap.enabled = true;
    options.refine.swap.knees_only = knees_only;
    const Eigen::VectorXd angles =
        refineAlone(model, rig, bent_masks, knees_crossed, options).tail(4);
    return (angles - bent.tail(4)).cwiseAbs().maxCoeff() / deg;
  };
  EXPECT_LT(kneeError(true), 2);
  EXPECT_GT(kneeError(false), 20);

  // A body without two feet cannot swap its legs, and says so.
  WorkerPool pool(1);
  FilterOptions options;
  options.refine.share = 0.5;
  options.refine.swap.enabled = true;
  try {
    makeFilter("factored", pelvisAndLegs(), rig, options, pool);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("refine_swap"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("feet"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mocap
