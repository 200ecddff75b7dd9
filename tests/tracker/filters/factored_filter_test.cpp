// The factored particle filter: it finds a known static pose from a perturbed start, spends exactly
// its budget, rasterizes candidates at one pose once, does not depend on the thread count,
// recovers a misplaced joint by injection (of one DOF, or of a whole segment's angles), and its
// full-body refinement corrects the layers (and, holding a segment's children, a turned pelvis).
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <tuple>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"
#include "tracker/motion/motion.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

using testing_support::HandScene;
using testing_support::silhouettes;

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
  options.injection_share = 0.1;  // exercise the random part too
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
  options.injection_share = 0;
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
  for (auto mode : {FilterOptions::Lookahead::kSubtree, FilterOptions::Lookahead::kBody}) {
    FilterOptions options;
    options.lookahead = mode;
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
}

TEST(FactoredFilter, RefinementTakesWhatTheLayersLeaveOfTheBudgetUpToItsCap) {
  HandScene scene;
  const Motion motion = generateMotion(scene.model, 3, 5);
  // At 375: S = 3 at shares 0.2 and 0.4 (225 in the layers), 1 at 0.7 (75); a cap of 30 leaves
  // 225 + 30 spent, one above the layers' share leaves the budget as it was.
  for (const auto& [share, cap, spent] :
       {std::tuple{0.2, 0, 375}, {0.4, 0, 375}, {0.7, 0, 375}, {0.2, 30, 255}, {0.2, 500, 375}}) {
    FilterOptions options;
    options.refine_share = share;
    options.refine_max_evaluations = cap;
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
  bad.refine_share = 1.0;
  EXPECT_THROW(makeFilter("factored", scene.model, scene.rig, bad, pool), std::invalid_argument);
  bad.refine_share = 0.2;
  bad.refine_max_evaluations = -1;
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
      options.refine_share = refined ? 0.4 : 0.0;
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
  options.refine_share = 0.95;
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
  options.refine_share = 0.4;  // 15 layers x 5 x 3 = 225, so the refinement gets 150
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
  options.refine_share = 0.4;
  options.injection_share = 0.1;
  options.lookahead = FilterOptions::Lookahead::kBody;
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
    options.injection_share = share;
    auto filter = makeFilter("factored", scene.model, scene.rig, options, pool);
    filter->reset(start);
    FrameEstimate e;
    for (int f = 0; f < frames; ++f) e = filter->step(masks);
    return std::abs(e.q[mcp] - truth[mcp]) * 180 / M_PI;
  };
  EXPECT_GT(mcpErrorAfter(0.0, 4), 25.0);  // physically limited: 60 - 4 x 8 = 28 degrees left
  EXPECT_LT(mcpErrorAfter(0.1, 4), 10.0);
}

// Two 240x180 cameras 90 degrees apart, 3 m from the vertical axis at `height`, looking at
// `target`.
Rig twoCameras(const Eigen::Vector3d& target, double height) {
  Rig rig;
  for (int i = 0; i < 2; ++i) {
    const double azimuth = (30.0 + 90.0 * i) * M_PI / 180;
    rig.push_back(
        CameraModel::lookAt("cam" + std::to_string(i),
                            Eigen::Vector3d(3 * std::cos(azimuth), 3 * std::sin(azimuth), height),
                            target, Eigen::Vector3d::UnitZ(), 240, 180, 200));
  }
  return rig;
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
  auto trackedHandError = [&](FilterOptions::Injection injection) {
    WorkerPool pool(1);
    FilterOptions options;
    options.evaluations_per_frame = 200;
    options.injection_share = 0.2;
    options.injection = injection;
    auto filter = makeFilter("factored", model, rig, options, pool);
    filter->reset(start);
    FrameEstimate e;
    for (int f = 0; f < 30; ++f) e = filter->step(masks);
    return handError(e.q);
  };
  ASSERT_GT(handError(start), 0.5);
  EXPECT_LT(trackedHandError(FilterOptions::Injection::kSegment), 0.03);
  EXPECT_GT(trackedHandError(FilterOptions::Injection::kDof), 0.2);
}

// A pelvis turning about the vertical with two legs on ball joints (flex, abduct, twist).
BodyModel pelvisAndLegs() {
  return parseBodyModel(R"(
name: pelvis_and_legs
segments:
  - name: pelvis
    dofs:
      - {name: yaw, axis: [0, 0, 1], min: -180, max: 180, max_speed: 6}
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.2, 0.1, 0.12]}
  - name: r_leg
    parent: pelvis
    offset: [0.12, 0, -0.08]
    dofs:
      - {name: r_flex, axis: [1, 0, 0], min: -90, max: 90, max_speed: 6}
      - {name: r_abduct, axis: [0, -1, 0], min: -90, max: 90, max_speed: 6}
      - {name: r_twist, axis: [0, 0, 1], min: -90, max: 90, max_speed: 6}
    shape: {type: cone, axis: [0, 0, -1], length: 0.8, radius_start: 0.07, radius_end: 0.05}
    points: [{name: r_foot, at: [0, 0, -0.8]}]
  - name: l_leg
    parent: pelvis
    offset: [-0.12, 0, -0.08]
    dofs:
      - {name: l_flex, axis: [1, 0, 0], min: -90, max: 90, max_speed: 6}
      - {name: l_abduct, axis: [0, 1, 0], min: -90, max: 90, max_speed: 6}
      - {name: l_twist, axis: [0, 0, -1], min: -90, max: 90, max_speed: 6}
    shape: {type: cone, axis: [0, 0, -1], length: 0.8, radius_start: 0.07, radius_end: 0.05}
    points: [{name: l_foot, at: [0, 0, -0.8]}]
)",
                        "pelvis_and_legs.yaml");
}

// The estimate after 10 frames of the factored filter from `start` with `options` (400
// evaluations) and its refinement alone: at a share of 0.95 the layers sample only the interval's
// centre, and nothing is injected.
Eigen::VectorXd refineAlone(const BodyModel& model, const Rig& rig,
                            const std::vector<SilhouetteMask>& masks, const Eigen::VectorXd& start,
                            FilterOptions options) {
  WorkerPool pool(1);
  options.evaluations_per_frame = 400;
  options.refine_share = 0.95;
  options.injection_share = 0;
  auto filter = makeFilter("factored", model, rig, options, pool);
  filter->reset(start);
  FrameEstimate e;
  for (int f = 0; f < 10; ++f) e = filter->step(masks);
  return e.q;
}

// The start of a track that went wrong from `truth` (the pelvis's yaw, then each leg's three
// angles, segments 1 and 2): the pelvis turned 40 degrees, each leg's angles solved so it points
// as in truth.
Eigen::VectorXd turnedPelvis(const BodyModel& model, const Eigen::VectorXd& truth) {
  const double deg = M_PI / 180;
  Eigen::VectorXd start = truth;
  start[0] = 40 * deg;
  for (int leg = 0; leg < 2; ++leg) {
    const Segment& seg = model.segments[1 + leg];
    const Eigen::Matrix3d local = Eigen::AngleAxisd(-start[0], Eigen::Vector3d::UnitZ()) *
                                  localTransform(model, 1 + leg, truth).linear();
    // Of the two angle triples giving that rotation, the one with the smaller angles.
    const auto wrapped = [](const Eigen::Vector3d& a) {
      return Eigen::Vector3d(a.unaryExpr([](double x) { return std::remainder(x, 2 * M_PI); }));
    };
    const Eigen::Vector3d euler = local.eulerAngles(0, 1, 2);
    Eigen::Vector3d xyz = wrapped(euler);
    const Eigen::Vector3d other =
        wrapped(Eigen::Vector3d(euler[0] + M_PI, M_PI - euler[1], euler[2] + M_PI));
    if (other.cwiseAbs().sum() < xyz.cwiseAbs().sum()) xyz = other;
    for (int j = 0; j < 3; ++j) {
      const Dof& dof = model.dofs[seg.dofs[j]];
      start[seg.dofs[j]] = dof.axis.sum() * xyz[j];
      EXPECT_GT(start[seg.dofs[j]], dof.min) << dof.name;
      EXPECT_LT(start[seg.dofs[j]], dof.max) << dof.name;
    }
    EXPECT_TRUE(localTransform(model, 1 + leg, start).linear().isApprox(local, 1e-9)) << leg;
  }
  return start;
}

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
    options.refine_hold = hold;
    return std::abs(refineAlone(model, rig, masks, start, options)[0]) / deg;
  };
  EXPECT_LT(trackedYaw(true), 3);
  EXPECT_GT(trackedYaw(false), 20);
}

// A round pelvis whose legs (with knees) hang from its centre: turned with its legs held, it casts
// the same silhouettes, so they cannot tell its heading. The facing prior, which charges the hips'
// common twist, turns it back to face where the legs do; without it the pelvis stays turned.
TEST(FactoredFilter, FacingPriorTurnsARoundPelvisToFaceItsLegs) {
  const BodyModel model = parseBodyModel(R"(
name: round_pelvis_and_legs
facing_twists: [r_twist, l_twist]
segments:
  - name: pelvis
    dofs:
      - {name: yaw, axis: [0, 0, 1], min: -180, max: 180, max_speed: 6}
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.15, 0.15, 0.12]}
  - name: r_thigh
    parent: pelvis
    offset: [0, 0, -0.08]
    dofs:
      - {name: r_flex, axis: [1, 0, 0], min: -90, max: 90, max_speed: 6}
      - {name: r_abduct, axis: [0, -1, 0], min: -90, max: 90, max_speed: 6}
      - {name: r_twist, axis: [0, 0, 1], min: -90, max: 90, max_speed: 6}
    shape: {type: cone, axis: [0, 0, -1], length: 0.4, radius_start: 0.07, radius_end: 0.05}
  - name: l_thigh
    parent: pelvis
    offset: [0, 0, -0.08]
    dofs:
      - {name: l_flex, axis: [1, 0, 0], min: -90, max: 90, max_speed: 6}
      - {name: l_abduct, axis: [0, 1, 0], min: -90, max: 90, max_speed: 6}
      - {name: l_twist, axis: [0, 0, -1], min: -90, max: 90, max_speed: 6}
    shape: {type: cone, axis: [0, 0, -1], length: 0.4, radius_start: 0.07, radius_end: 0.05}
  - name: r_shin
    parent: r_thigh
    offset: [0, 0, -0.4]
    dofs: [{name: r_knee, axis: [1, 0, 0], min: -150, max: 0, max_speed: 6}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.4, radius_start: 0.05, radius_end: 0.04}
  - name: l_shin
    parent: l_thigh
    offset: [0, 0, -0.4]
    dofs: [{name: l_knee, axis: [1, 0, 0], min: -150, max: 0, max_speed: 6}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.4, radius_start: 0.05, radius_end: 0.04}
)",
                                         "round_pelvis_and_legs.yaml");
  const Rig rig = twoCameras(Eigen::Vector3d(0, 0, -0.3), -0.2);
  const double deg = M_PI / 180;
  Eigen::VectorXd truth(9);
  truth << 0, 35 * deg, 0, 0, -25 * deg, 0, 0, -40 * deg, -20 * deg;  // a stride, knees bent
  const Eigen::VectorXd start = turnedPelvis(model, truth);
  const std::vector<SilhouetteMask> masks = silhouettes(model, rig, truth);
  // The silhouettes do not tell the two apart.
  const std::vector<SilhouetteMask> turned = silhouettes(model, rig, start);
  for (std::size_t c = 0; c < rig.size(); ++c)
    ASSERT_EQ(cv::countNonZero(turned[c].toMat() != masks[c].toMat()), 0) << c;

  auto trackedYaw = [&](double facing_prior) {
    FilterOptions options;
    options.refine_hold = true;
    options.refine_facing_prior = facing_prior;
    return std::abs(refineAlone(model, rig, masks, start, options)[0]) / deg;
  };
  // Weak: where the silhouettes tie it decides; a strong prior on this small body also untwists
  // the thighs at the cost of the shins' silhouettes and stops part way (17-21 degrees at 0.5-16).
  EXPECT_LT(trackedYaw(0.05), 3);
  EXPECT_GT(trackedYaw(0), 20);
}

// A pelvis that moves up and down on two legs of hip, knee and foot, with the model's `feet`.
BodyModel legsWithFeet() {
  return parseBodyModel(R"(
name: legs_with_feet
feet: [r_foot, l_foot]
segments:
  - name: pelvis
    offset: [0, 0, 0.9]
    dofs:
      - {name: height, type: translation, axis: [0, 0, 1], min: -0.5, max: 0.5, max_speed: 0.03}
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.12, 0.08, 0.06]}
  - name: r_thigh
    parent: pelvis
    offset: [0.1, 0, -0.05]
    dofs: [{name: r_hip, axis: [1, 0, 0], min: -30, max: 120, max_speed: 20}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.04, radius_end: 0.03}
  - name: r_shin
    parent: r_thigh
    offset: [0, 0, -0.42]
    dofs: [{name: r_knee, axis: [-1, 0, 0], min: 0, max: 150, max_speed: 32}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.03, radius_end: 0.025}
  - name: r_foot
    parent: r_shin
    offset: [0, 0, -0.42]
    shape: {type: ellipsoid, center: [0, 0.08, -0.04], radii: [0.07, 0.16, 0.05]}
  - name: l_thigh
    parent: pelvis
    offset: [-0.1, 0, -0.05]
    dofs: [{name: l_hip, axis: [1, 0, 0], min: -30, max: 120, max_speed: 20}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.04, radius_end: 0.03}
  - name: l_shin
    parent: l_thigh
    offset: [0, 0, -0.42]
    dofs: [{name: l_knee, axis: [-1, 0, 0], min: 0, max: 150, max_speed: 32}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.03, radius_end: 0.025}
  - name: l_foot
    parent: l_shin
    offset: [0, 0, -0.42]
    shape: {type: ellipsoid, center: [0, 0.08, -0.04], radii: [0.07, 0.16, 0.05]}
)",
                        "legs_with_feet.yaml");
}

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
    options.refine_share = 0.95;
    options.injection_share = 0;
    options.refine_plant = plant;
    auto filter = makeFilter("factored", model, rig, options, pool);
    filter->reset(start);
    return std::abs(filter->step(masks).q[0] - truth[0]);
  };
  EXPECT_LT(heightError(true), 0.01);
  EXPECT_GT(heightError(false), 0.03);
}

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
    options.refine_restart_share = share;
    return footError(refineAlone(model, rig, masks, start, options));
  };
  ASSERT_GT(footError(start), 1.0);
  EXPECT_LT(trackedFootError(0.3), 0.03);  // 27 draws
  EXPECT_GT(trackedFootError(0), 0.3);
}

// Two cameras at 480x360 on legsWithFeet (twoCameras' geometry, twice the focal length and size),
// so the legs cover enough pixels for the swap's default margin and the chase's blobs.
Rig twoCamerasOnTheLegs() {
  Rig rig;
  for (const CameraModel& small : twoCameras(Eigen::Vector3d(0, 0, 0.5), 0.6))
    rig.push_back(CameraModel::lookAt(small.name, small.center(), Eigen::Vector3d(0, 0, 0.5),
                                      Eigen::Vector3d::UnitZ(), 480, 360, 400));
  return rig;
}

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
    options.refine_swap = swap;
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
    options.refine_swap = true;
    options.refine_swap_knees_only = knees_only;
    const Eigen::VectorXd angles =
        refineAlone(model, rig, bent_masks, knees_crossed, options).tail(4);
    return (angles - bent.tail(4)).cwiseAbs().maxCoeff() / deg;
  };
  EXPECT_LT(kneeError(true), 2);
  EXPECT_GT(kneeError(false), 20);

  // A body without two feet cannot swap its legs, and says so.
  WorkerPool pool(1);
  FilterOptions options;
  options.refine_share = 0.5;
  options.refine_swap = true;
  try {
    makeFilter("factored", pelvisAndLegs(), rig, options, pool);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("refine_swap"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("feet"), std::string::npos) << e.what();
  }
}

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
    options.refine_unexplained = chase;
    return std::abs(refineAlone(model, rig, masks, start, options)[1] - truth[1]) / deg;
  };
  EXPECT_LT(hipError(true), 3);
  EXPECT_GT(hipError(false), 40);
}

TEST(FactoredFilter, OptionNamesAreParsedAndBadOnesNamed) {
  EXPECT_EQ(parseInjection("segment"), FilterOptions::Injection::kSegment);
  EXPECT_EQ(parseInjection("dof"), FilterOptions::Injection::kDof);
  EXPECT_EQ(parseLookahead("body"), FilterOptions::Lookahead::kBody);
  try {
    parseInjection("limb");
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'limb'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parseLookahead("everything"), std::invalid_argument);
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
