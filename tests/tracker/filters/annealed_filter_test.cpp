// The annealed particle filter: it spends its budget over its layers, approaches a static pose, and
// is deterministic across thread counts for a seed.
#include <gtest/gtest.h>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"
#include "tracker/motion/motion.h"

namespace mocap {
namespace {

using testing_support::HandScene;

TEST(AnnealedFilter, ApproachesAStaticPoseAndSpendsItsBudget) {
  HandScene scene;
  const Eigen::VectorXd truth = generateMotion(scene.model, 1, 9)[0];
  const auto masks = scene.masks(truth);
  WorkerPool pool(2);
  FilterOptions options;
  options.evaluations_per_frame = 400;
  options.annealing_layers = 4;
  auto filter = makeFilter("annealed", scene.model, scene.rig, options, pool);
  const Eigen::VectorXd start = scene.perturbed(truth, 2.0);
  const double start_error = scene.pointError(start, truth);
  filter->reset(start);
  FrameEstimate e;
  for (int f = 0; f < 12; ++f) e = filter->step(masks);
  EXPECT_EQ(e.evaluations, 400);  // 4 layers x 100 particles
  EXPECT_LT(scene.pointError(e.q, truth), 0.5 * start_error);
}

TEST(AnnealedFilter, ResultsDoNotDependOnTheThreadCount) {
  testing_support::expectSameEstimatesForThreadCounts("annealed", FilterOptions(), {1, 2}, 3);
}

}  // namespace
}  // namespace mocap
