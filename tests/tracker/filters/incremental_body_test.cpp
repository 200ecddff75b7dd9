// The incremental full-body evaluator: after a reset and along a random sequence of trials (one
// DOF, or several at once like the pattern move), accepted or rejected at random, every count
// equals FullBodyEvaluator::evaluate's for the same pose, a rejected trial leaves the state as it
// was, and the state reached trial by trial counts as a fresh reset at the current pose. On the
// hand and the human.
#include <filesystem>
#include <random>

#include <gtest/gtest.h>

#include "tests/shared_data.h"
#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"
#include "tracker/filters/incremental_body.h"
#include "tracker/likelihood/full_body.h"
#include "tracker/model/builtin_models.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/motion.h"
#include "tracker/motion/retarget.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

void expectSameCounts(const PixelCounts& a, const PixelCounts& b, const std::string& what) {
  EXPECT_EQ(a.matched, b.matched) << what;
  EXPECT_EQ(a.outside, b.outside) << what;
  EXPECT_EQ(a.area, b.area) << what;
}

using testing_support::silhouettes;

// Random trials from `start` against the silhouettes of `truth`; steps of up to `speeds` speed
// limits, so footprints move by a few pixels to many. With `threads` > 1 the evaluator runs each
// camera's part on a pool's workers.
void checkRandomTrials(const BodyModel& model, const Rig& rig, const Eigen::VectorXd& truth,
                       const Eigen::VectorXd& start, int trials, unsigned seed, double speeds,
                       int threads = 1) {
  const auto masks = silhouettes(model, rig, truth);
  FullBodyEvaluator full(model, rig, LikelihoodParams().points_per_circle, 1);
  WorkerPool pool(threads);
  IncrementalBodyEvaluator incremental(model, rig, LikelihoodParams().points_per_circle, &pool);
  expectSameCounts(incremental.reset(start, masks), full.evaluate(start, masks, 0), "reset");
  ASSERT_GT(incremental.counts().matched, 1000) << "area " << incremental.counts().area;
  std::vector<int> free_dofs;
  for (std::size_t d = 0; d < model.dofs.size(); ++d)
    if (model.dofs[d].isFree()) free_dofs.push_back(static_cast<int>(d));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> step(-speeds, speeds);
  int accepted = 0;
  for (int t = 0; t < trials; ++t) {
    Eigen::VectorXd q = incremental.pose();
    const int changed = rng() % 8 == 0 ? 1 + static_cast<int>(rng() % free_dofs.size()) : 1;
    for (int i = 0; i < changed; ++i) {
      const int d = free_dofs[rng() % free_dofs.size()];
      q[d] += step(rng) * model.dofs[d].max_speed;
    }
    clampToLimits(model, q);
    const std::string what = "trial " + std::to_string(t);
    const PixelCounts before = incremental.counts();
    const Eigen::VectorXd pose_before = incremental.pose();
    expectSameCounts(incremental.trial(q), full.evaluate(q, masks, 0), what);
    if (rng() % 2) {
      incremental.accept();
      ++accepted;
      EXPECT_EQ(incremental.pose(), q) << what;
      expectSameCounts(incremental.counts(), full.evaluate(q, masks, 0), what + " accepted");
    } else {
      incremental.reject();
      EXPECT_EQ(incremental.pose(), pose_before) << what;
      expectSameCounts(incremental.counts(), before, what + " rejected");
    }
  }
  EXPECT_GT(accepted, trials / 4);
  IncrementalBodyEvaluator fresh(model, rig, LikelihoodParams().points_per_circle);
  expectSameCounts(fresh.reset(incremental.pose(), masks), incremental.counts(), "final");
}

TEST(IncrementalBodyEvaluator, HandTrialsMatchTheFullEvaluation) {
  testing_support::HandScene scene;
  const Eigen::VectorXd truth = generateMotion(scene.model, 1, 9)[0];
  checkRandomTrials(scene.model, scene.rig, truth, scene.perturbed(truth, 2.0), 400, 1, 1.5);
  // Large steps: footprints jump clear of where they were.
  checkRandomTrials(scene.model, scene.rig, truth, scene.perturbed(truth, 2.0), 200, 2, 8.0);
}

TEST(IncrementalBodyEvaluator, HandTrialsOnTwoThreadsMatchTheFullEvaluation) {
  testing_support::HandScene scene;  // 3 cameras over 2 workers: one takes two
  const Eigen::VectorXd truth = generateMotion(scene.model, 3, 9)[0];
  checkRandomTrials(scene.model, scene.rig, truth, scene.perturbed(truth, 2.0), 300, 4, 1.5, 2);
}

// The human as `mocap-experiment human` sets it up (the CMU walk, fitted and retargeted, the lab
// rig), at half the resolution.
TEST(IncrementalBodyEvaluator, HumanTrialsMatchTheFullEvaluation) {
  const std::string path = std::string(MOCAP_SHARED_DIR) + "/data/motion/cmu_131_01_walk.bvh";
  REQUIRE_SHARED_FILE(path);
  const Bvh bvh = loadBvh(path);
  const BodyModel model = fitModelToBvh(builtinHumanModel(), bvh.skeleton);
  const Motion motion = retargetBvh(model, bvh.skeleton, bvh.motion, 25, 10).motion;
  const Rig rig = labRig(2, model, motion, 390, 290);
  checkRandomTrials(model, rig, motion[9], motion[5], 300, 3, 2.0);
  checkRandomTrials(model, rig, motion[9], motion[5], 150, 5, 2.0, 2);
}

TEST(IncrementalBodyEvaluator, ResetClearsThePreviousFrame) {
  testing_support::HandScene scene;
  const Motion motion = generateMotion(scene.model, 2, 4);
  IncrementalBodyEvaluator incremental(scene.model, scene.rig,
                                       LikelihoodParams().points_per_circle);
  FullBodyEvaluator full(scene.model, scene.rig, LikelihoodParams().points_per_circle, 1);
  const auto first = scene.masks(motion[0]), second = scene.masks(motion[1]);
  // The same fingertip DOF tried in both frames: what the first frame learnt of the rest of the
  // body must not carry over.
  const int d = scene.model.segments[scene.model.segmentIndex("index_3")].dofs[0];
  const auto tipMoved = [&](Eigen::VectorXd q) {
    q[d] = 0.5 * (scene.model.dofs[d].min + scene.model.dofs[d].max);
    return q;
  };
  incremental.reset(motion[0], first);
  incremental.trial(tipMoved(motion[0]));  // left pending: the reset drops it
  incremental.reset(motion[1], second);
  expectSameCounts(incremental.counts(), full.evaluate(motion[1], second, 0), "second frame");
  expectSameCounts(incremental.trial(tipMoved(motion[1])),
                   full.evaluate(tipMoved(motion[1]), second, 0), "trial in the second frame");
}

TEST(IncrementalBodyEvaluator, RasterizesOnlyTheMovedSubtree) {
  testing_support::HandScene scene;
  const Eigen::VectorXd q = scene.model.neutralPose();
  IncrementalBodyEvaluator incremental(scene.model, scene.rig,
                                       LikelihoodParams().points_per_circle);
  const auto masks = scene.masks(q);  // the evaluator keeps them
  incremental.reset(q, masks);
  const long after_reset = incremental.renders();
  // A fingertip's DOF moves that one segment only.
  const int tip = scene.model.segmentIndex("index_3");
  ASSERT_GE(tip, 0);
  ASSERT_FALSE(scene.model.segments[tip].dofs.empty());
  Eigen::VectorXd moved = q;
  const int d = scene.model.segments[tip].dofs[0];
  moved[d] = scene.model.dofs[d].min + 0.5 * (scene.model.dofs[d].max - scene.model.dofs[d].min);
  ASSERT_NE(moved[d], q[d]);
  incremental.trial(moved);
  incremental.reject();
  EXPECT_EQ(incremental.renders() - after_reset, 1);
}

}  // namespace
}  // namespace mocap
