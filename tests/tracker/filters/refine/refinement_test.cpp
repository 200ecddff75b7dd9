// The factored filter's full-body refinement: it takes what the layers leave of the budget (up to
// its cap), ends nearer the truth than the layers alone, stops once no step moves, yields to a
// newer frame when asked, and does not depend on the thread count.
#include <gtest/gtest.h>

#include <functional>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"
#include "tracker/motion/motion.h"

namespace mocap {
namespace {

using testing_support::HandScene;

TEST(FactoredFilter, RefinementTakesWhatTheLayersLeaveOfTheBudgetUpToItsCap) {
  HandScene scene;
  const Motion motion = generateMotion(scene.model, 3, 5);
  // At 375: S = 3 at shares 0.2 and 0.4 (225 in the layers), 1 at 0.7 (75); a cap of 30 leaves
  // 225 + 30 spent, one above the layers' share leaves the budget as it was.
  for (const auto& [share, cap, spent] :
       {std::tuple{0.2, 0, 375}, {0.4, 0, 375}, {0.7, 0, 375}, {0.2, 30, 255}, {0.2, 500, 375}}) {
    FilterOptions options;
    options.refine.share = share;
    options.refine.max_evaluations = cap;
    WorkerPool pool(1);
    auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
    filter->reset(motion[0]);
    for (const auto& q : motion) {
      const FrameEstimate e = filter->step(scene.masks(q));
      EXPECT_EQ(e.evaluations, spent) << "share " << share << ", cap " << cap;
    }
  }
  WorkerPool pool(1);
  FilterOptions bad;
  bad.refine.share = 1.0;
  EXPECT_THROW(makeFilter("factored", scene.model, scene.rig, bad, pool), std::invalid_argument);
  bad.refine.share = 0.2;
  bad.refine.max_evaluations = -1;
  EXPECT_THROW(makeFilter("factored", scene.model, scene.rig, bad, pool), std::invalid_argument);
}

// The layers place each DOF with the later segments where they stood a frame ago; the pattern
// search on the whole body corrects that, so at the same budget one frame ends nearer the truth.
TEST(FactoredFilter, RefinementEndsNearerTheTruthAtTheSameBudget) {
  HandScene scene;
  double error[2];
  for (int refined = 0; refined < 2; ++refined) {
    double sum = 0;
    for (uint64_t seed : {3, 9, 21}) {
      const Eigen::VectorXd truth = generateMotion(scene.model, 1, seed)[0];
      FilterOptions options;
      options.refine.share = refined ? 0.4 : 0.0;
      WorkerPool pool(1);
      auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
      filter->reset(scene.perturbed(truth, 0.7));
      sum += scene.pointError(filter->step(scene.masks(truth)).q, truth);
    }
    error[refined] = sum / 3;
  }
  EXPECT_LT(error[1], 0.7 * error[0])
      << "refined " << error[1] << " m, layers only " << error[0] << " m";
}

// A budget far beyond what a converged pose needs: the steps shrink until they no longer move a
// DOF, and the search must stop there instead of spinning on the budget it cannot spend.
TEST(FactoredFilter, RefinementStopsWhenNoStepMovesAnyMore) {
  HandScene scene;
  const Eigen::VectorXd truth = generateMotion(scene.model, 1, 9)[0];
  const auto masks = scene.masks(truth);
  FilterOptions options;
  options.evaluations_per_frame = 100000;
  options.refine.share = 0.95;
  WorkerPool pool(1);
  auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
  filter->reset(truth);
  const FrameEstimate e = filter->step(masks);
  EXPECT_LT(e.evaluations, options.evaluations_per_frame);
  EXPECT_LT(scene.pointError(e.q, truth), 0.002);
}

// Live, the refinement gives way to a newer frame: asked to yield after a few checks it stops
// there and says so; never asked, it is the refinement with no check at all, to the bit.
TEST(FactoredFilter, RefinementYieldsToANewerFrameWhenAsked) {
  HandScene scene;
  const Motion motion = generateMotion(scene.model, 3, 5);
  FilterOptions options;
  options.refine.share = 0.4;  // 15 layers x 5 x 3 = 225, so the refinement gets 150
  auto run = [&](const std::function<bool()>& yield) {
    WorkerPool pool(1);
    auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
    if (yield) filter->setYield(yield);
    filter->reset(motion[0]);
    std::vector<FrameEstimate> estimates;
    for (const auto& q : motion) estimates.push_back(filter->step(scene.masks(q)));
    return estimates;
  };
  const std::vector<FrameEstimate> plain = run(nullptr);
  const std::vector<FrameEstimate> never = run([] { return false; });
  int checks = 0;
  const std::vector<FrameEstimate> cut = run([&] { return ++checks % 8 == 0; });
  for (std::size_t f = 0; f < plain.size(); ++f) {
    EXPECT_EQ(plain[f].evaluations, 375);
    EXPECT_FALSE(plain[f].cut_short);
    EXPECT_EQ(never[f].q, plain[f].q) << "frame " << f;
    EXPECT_FALSE(never[f].cut_short);
    // The layers' 225 and the refinement's first score, then seven DOFs of the first sweep
    // before the eighth check yields: up to 2 trials each (none for a DOF held at a limit).
    EXPECT_TRUE(cut[f].cut_short) << "frame " << f;
    EXPECT_GE(cut[f].evaluations, 225 + 1) << "frame " << f;
    EXPECT_LE(cut[f].evaluations, 225 + 1 + 7 * 2) << "frame " << f;
  }
}

TEST(FactoredFilter, RefinementDoesNotDependOnTheThreadCount) {
  FilterOptions options;
  options.refine.share = 0.4;
  options.injection.share = 0.1;
  options.lookahead = FilterOptions::Lookahead::kBody;
  testing_support::expectSameEstimatesForThreadCounts("factored", options, {1, 2}, 4);
}

}  // namespace
}  // namespace mocap
