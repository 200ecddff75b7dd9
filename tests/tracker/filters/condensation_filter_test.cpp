// Condensation: it spends its budget, approaches a static pose, and is deterministic across thread
// counts for a seed.
#include <gtest/gtest.h>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"
#include "tracker/motion/motion.h"

namespace mocap {
namespace {

using testing_support::HandScene;

TEST(CondensationFilter, ApproachesAStaticPoseFromAPerturbedStart) {
  HandScene scene;
  const Eigen::VectorXd truth = generateMotion(scene.model, 1, 9)[0];
  const auto masks = scene.masks(truth);
  WorkerPool pool(2);
  FilterOptions options;
  auto filter = makeFilter("condensation", scene.model, scene.rig, options, pool);
  const Eigen::VectorXd start = scene.perturbed(truth, 2.0);
  const double start_error = scene.pointError(start, truth);
  filter->reset(start);
  FrameEstimate e;
  for (int f = 0; f < 12; ++f) e = filter->step(masks);
  EXPECT_EQ(e.evaluations, 375);
  EXPECT_EQ(e.segment_renders, 375 * 16);
  EXPECT_LT(scene.pointError(e.q, truth), 0.5 * start_error);
}

TEST(CondensationFilter, ResultsDoNotDependOnTheThreadCount) {
  FilterOptions options;
  options.seed = 5;
  testing_support::expectSameEstimatesForThreadCounts("condensation", options, {1, 3}, 4);
}

}  // namespace
}  // namespace mocap
