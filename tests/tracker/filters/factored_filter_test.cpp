// The factored particle filter: it finds a known static pose from a perturbed start, spends exactly
// its budget, rasterizes candidates at one pose once, does not depend on the thread count (with a
// look-ahead too), recovers a misplaced joint by injection (of one DOF, or of a whole segment's
// angles), gives frozen DOFs no layers and refuses what it cannot track. Its full-body refinement
// is tested in refine/.
#include <gtest/gtest.h>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"
#include "tracker/motion/motion.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

using testing_support::HandScene;
using testing_support::silhouettes;
using testing_support::twoCameras;

TEST(FactoredFilter, RecoversAStaticPoseFromAPerturbedStart) {
  HandScene scene;
  const Eigen::VectorXd truth = generateMotion(scene.model, 1, 9)[0];
  const auto masks = scene.masks(truth);
  WorkerPool pool(1);
  FilterOptions options;
  auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
  const Eigen::VectorXd start = scene.perturbed(truth, 3.0);
  ASSERT_GT(scene.pointError(start, truth), 0.010);  // the start is clearly off (> 10 mm)
  filter->reset(start);
  FrameEstimate e;
  for (int f = 0; f < 12; ++f) e = filter->step(masks);
  EXPECT_LT(scene.pointError(e.q, truth), 0.002);  // within 2 mm on average
  EXPECT_EQ(e.evaluations, 375);
}

TEST(FactoredFilter, BudgetScalesTheSamplesPerInterval) {
  HandScene scene;
  WorkerPool pool(1);
  FilterOptions options;
  options.evaluations_per_frame = 750;
  auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
  const Eigen::VectorXd q = scene.model.neutralPose();
  filter->reset(q);
  EXPECT_EQ(filter->step(scene.masks(q)).evaluations, 750);
}

TEST(FactoredFilter, ResultsDoNotDependOnTheThreadCount) {
  FilterOptions options;
  options.injection.share = 0.1;  // exercise the random part too
  options.seed = 77;
  testing_support::expectSameEstimatesForThreadCounts("factored", options, {1, 2, 3}, 6);
}

TEST(FactoredFilter, CandidatesAtOnePoseShareOneRasterization) {
  // From a reset every kept particle carries the same angles of the fingers not yet sampled, so the
  // first layer of each finger after the first draws the same 5 values from each of the 5 parents
  // on the same palm: 5 poses for 25 candidates, each rasterized once.
  HandScene scene;
  WorkerPool pool(1);
  FilterOptions options;
  options.injection.share = 0;
  auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
  const Eigen::VectorXd q = generateMotion(scene.model, 1, 3)[0];
  filter->reset(q);
  const FrameEstimate e = filter->step(scene.masks(q));
  EXPECT_EQ(e.evaluations, 375);
  EXPECT_LE(e.segment_renders, 1 + 375 - 4 * 20);  // the palm, then at least 4 × 20 shared
}

TEST(FactoredFilter, LookAheadKeepsTheBudgetAndThreadIndependence) {
  HandScene scene;
  const Motion motion = generateMotion(scene.model, 4, 6);
  FilterOptions options;
  options.lookahead = FilterOptions::Lookahead::kBody;
  WorkerPool pool(1);
  auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
  filter->reset(motion[0]);
  FrameEstimate e;
  for (const auto& q : motion) {
    e = filter->step(scene.masks(q));
    EXPECT_EQ(e.evaluations, 375);  // the look-ahead costs renders, not evaluations
    EXPECT_GT(e.segment_renders, 375);
  }
  EXPECT_LT(scene.pointError(e.q, motion.back()), 0.01);
  testing_support::expectSameEstimatesForThreadCounts("factored", options, {1, 2}, 4);
}

TEST(FactoredFilter, InjectionRecoversAJointBeyondTheSpeedLimit) {
  // The index MCP starts 60 degrees off. Interval sampling alone moves at most 8 degrees a frame;
  // static particle injection can jump there at once.
  HandScene scene;
  const int mcp = scene.model.dofIndex("index_mcp_flex");
  Eigen::VectorXd truth = scene.model.neutralPose();
  truth[mcp] = 70 * M_PI / 180;
  Eigen::VectorXd start = truth;
  start[mcp] = 10 * M_PI / 180;
  const auto masks = scene.masks(truth);
  auto mcpErrorAfter = [&](double share, int frames) {
    WorkerPool pool(1);
    FilterOptions options;
    options.injection.share = share;
    auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
    filter->reset(start);
    FrameEstimate e;
    for (int f = 0; f < frames; ++f) e = filter->step(masks);
    return std::abs(e.q[mcp] - truth[mcp]) * 180 / M_PI;
  };
  EXPECT_GT(mcpErrorAfter(0.0, 4), 25.0);  // physically limited: 60 - 4 x 8 = 28 degrees left
  EXPECT_LT(mcpErrorAfter(0.1, 4), 10.0);
}

// A limb swung far from where the tracker holds it (here: inside the trunk's side, while the truth
// raises it forward and sideways, beyond many speed limits in two DOFs at once). Redrawing one DOF
// at a time leaves the other where it was, so no injected candidate reaches the limb's silhouette;
// redrawing the segment's angles together does.
TEST(FactoredFilter, SegmentInjectionRecoversALimbThatNeedsTwoDofsAtOnce) {
  const BodyModel model = parseBodyModel(R"(
name: trunk_and_arm
segments:
  - name: trunk
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.15, 0.1, 0.3]}
  - name: arm
    parent: trunk
    offset: [0.08, 0, 0.2]
    dofs:
      - {name: flex, axis: [1, 0, 0], min: -60, max: 180, max_speed: 3}
      - {name: abduct, axis: [0, -1, 0], min: -30, max: 180, max_speed: 3}
    shape: {type: cone, axis: [0, 0, -1], length: 0.6, radius_start: 0.05, radius_end: 0.04}
    points: [{name: hand, at: [0, 0, -0.6]}]
)",
                                         "trunk_and_arm.yaml");
  const Rig rig = twoCameras(Eigen::Vector3d::Zero(), 0.3);
  Eigen::VectorXd truth(2), start(2);
  truth << 100 * M_PI / 180, 60 * M_PI / 180;
  start << 0, 0;
  const std::vector<SilhouetteMask> masks = silhouettes(model, rig, truth);

  // Distance (metres) of the hand at pose q from the true hand.
  auto handError = [&](const Eigen::VectorXd& q) {
    KinematicsData a(model), b(model);
    forwardKinematics(model, a, q);
    forwardKinematics(model, b, truth);
    return (pointPositions(model, a)[0] - pointPositions(model, b)[0]).norm();
  };
  auto trackedHandError = [&](InjectionOptions::Redraw redraw) {
    WorkerPool pool(1);
    FilterOptions options;
    options.evaluations_per_frame = 200;
    options.injection.share = 0.2;
    options.injection.redraw = redraw;
    auto filter = makeFilter("factored", model, rig, options, pool);
    filter->reset(start);
    FrameEstimate e;
    for (int f = 0; f < 30; ++f) e = filter->step(masks);
    return handError(e.q);
  };
  ASSERT_GT(handError(start), 0.5);
  EXPECT_LT(trackedHandError(InjectionOptions::Redraw::kSegment), 0.03);
  EXPECT_GT(trackedHandError(InjectionOptions::Redraw::kDof), 0.2);
}

TEST(FactoredFilter, FrozenDofsGetNoLayersAndKeepTheirValue) {
  HandScene scene;
  const Eigen::VectorXd truth = generateMotion(scene.model, 1, 2)[0];
  const BodyModel index_only =
      freezeAllBut(scene.model, {"index_mcp_flex", "index_pip_flex", "index_dip_flex"}, truth);
  WorkerPool pool(1);
  FilterOptions options;
  auto filter = makeFilter("factored", index_only, scene.rig, options, pool);
  filter->reset(scene.perturbed(truth, 1.0));
  const FrameEstimate e = filter->step(scene.masks(truth));
  EXPECT_EQ(e.evaluations, 375);  // 3 layers of 125 candidates: the budget goes to the free DOFs
  for (std::size_t d = 0; d < index_only.dofs.size(); ++d) {
    if (index_only.dofs[d].isFree()) continue;
    EXPECT_NEAR(e.q[d], truth[d], 1e-12) << index_only.dofs[d].name;
  }
}

TEST(FactoredFilter, RejectsAMovingSegmentWithoutShape) {
  const BodyModel m = parseBodyModel(R"(
segments:
  - name: a
    dofs: [{name: x, axis: [1, 0, 0], min: -10, max: 10, max_speed: 1}]
)",
                                     "shapeless");
  WorkerPool pool(1);
  Rig rig = {CameraModel()};
  EXPECT_THROW(makeFilter("factored", m, rig, FilterOptions(), pool), std::invalid_argument);
  EXPECT_THROW(makeFilter("nonsense", m, rig, FilterOptions(), pool), std::invalid_argument);
}

}  // namespace
}  // namespace mocap
