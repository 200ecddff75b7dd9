// Retargeting CMU motion onto the human model: time resampling, the body fitted to the subject's
// bone lengths, the IK residual on the real walk, joint limits, and IK recovering a known pose.
#include "tracker/motion/retarget.h"
#include "tests/shared_data.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <random>

#include "tracker/model/kinematics.h"

namespace mocap {
namespace {

const std::string kMotionDir = testing_support::kSharedMotionDir;

BodyModel humanModel() {
  return loadBodyModel(std::string(MOCAP_SOURCE_DIR) + "/tracker/models/human.yaml");
}

#define REQUIRE_SHARED_MOTION(file) REQUIRE_SHARED_FILE(kMotionDir + (file))

TEST(Retarget, ResamplesByTime) {
  // 995 frames at 120 Hz last 994/120 = 8.283 s: frames at 0, 0.04, ... 8.28 s.
  EXPECT_EQ(resampledFrameCount(995, 0.008333, 25), 208);
  EXPECT_EQ(resampledFrameCount(995, 1.0 / 120, 25), 208);
  EXPECT_EQ(resampledFrameCount(121, 1.0 / 120, 25), 26);  // exactly 1 s: both ends
  EXPECT_EQ(resampledFrameCount(1, 1.0 / 120, 25), 1);
  EXPECT_EQ(resampledFrameCount(0, 1.0 / 120, 25), 0);
}

TEST(Retarget, FittedBonesHaveTheSubjectsLengths) {
  REQUIRE_SHARED_MOTION("cmu_131_01_walk.bvh");
  const BodyModel model = humanModel();
  const Bvh walk = loadBvh(kMotionDir + "cmu_131_01_walk.bvh");
  const BodyModel fitted = fitModelToBvh(model, walk.skeleton);
  const std::vector<BoneLength> subject = subjectBoneLengths(model, walk.skeleton);
  const std::vector<BoneLength> before = modelBoneLengths(model);
  const std::vector<BoneLength> after = modelBoneLengths(fitted);
  ASSERT_EQ(subject.size(), after.size());
  int changed = 0;
  for (std::size_t b = 0; b < subject.size(); ++b) {
    EXPECT_EQ(after[b].name, subject[b].name);
    EXPECT_NEAR(after[b].length, subject[b].length, 1e-9) << subject[b].name;
    changed += std::abs(before[b].length - subject[b].length) > 0.01;
  }
  EXPECT_GE(changed, 10);  // the subject is not the default body
  // The structure is kept: same DOFs, limits and points.
  EXPECT_EQ(fitted.dofs.size(), model.dofs.size());
  EXPECT_EQ(fitted.points.size(), model.points.size());
  // The fitted body stands on the floor where the model stood (legs differ by a few mm).
  KinematicsData data(fitted);
  forwardKinematics(fitted, data, fitted.neutralPose());
  const std::vector<Eigen::Vector3d> points = pointPositions(fitted, data);
  EXPECT_NEAR(points[fitted.pointIndex("l_ankle")].z() + points[fitted.pointIndex("r_ankle")].z(),
              2 * 0.07, 1e-9);
}

// Fitted to its own rest points, a body whose hip joints hang below its root (the experiments'
// hips-below body) keeps its points and trunk shapes where they were, the spine bent or not,
// although the fit puts its root between the hips.
TEST(Retarget, ABodyFittedToItsOwnRestPointsKeepsItsShape) {
  const BodyModel model = loadBodyModel(std::string(MOCAP_SOURCE_DIR) +
                                        "/tracker/experiments/models/human_hips_below_pelvis.yaml");
  ASSERT_LT(model.segments[model.points[model.pointIndex("l_hip")].segment].offset.z(), -0.01);
  KinematicsData data(model);
  forwardKinematics(model, data, model.neutralPose());
  const BodyModel fitted = fitModelToRestPoints(model, pointPositions(model, data));
  Eigen::VectorXd bent = model.neutralPose();
  bent[model.dofIndex("spine_flex")] = 0.6;
  bent[model.dofIndex("r_hip_flex")] = 0.4;
  KinematicsData fitted_data(fitted);
  for (const Eigen::VectorXd& q : {model.neutralPose(), bent}) {
    forwardKinematics(model, data, q);
    forwardKinematics(fitted, fitted_data, q);
    const std::vector<Eigen::Vector3d> expected = pointPositions(model, data);
    const std::vector<Eigen::Vector3d> got = pointPositions(fitted, fitted_data);
    for (std::size_t p = 0; p < expected.size(); ++p)
      EXPECT_LT((got[p] - expected[p]).norm(), 1e-9) << model.points[p].name;
    for (const char* segment : {"pelvis", "chest"}) {
      const int s = model.segmentIndex(segment);
      EXPECT_LT((fitted_data.world[s] * fitted.segments[s].shape.center -
                 data.world[s] * model.segments[s].shape.center)
                    .norm(),
                1e-9)
          << segment;
    }
  }
}

TEST(Retarget, AxisMapTakesYUpToZUp) {
  REQUIRE_SHARED_MOTION("cmu_131_01_walk.bvh");
  const Bvh walk = loadBvh(kMotionDir + "cmu_131_01_walk.bvh");
  const AxisMap axes = bvhToModelAxes(humanModel(), walk.skeleton);
  EXPECT_TRUE((axes.rotation * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d::UnitZ(), 1e-9));
  EXPECT_TRUE((axes.rotation * axes.rotation.transpose()).isIdentity(1e-12));
}

// The common CMU release's files (cgspeed naming, CMU units, a reference T-pose first) give a body
// of a person's size that stands on the floor and starts in the motion, not in the T-pose.
TEST(Retarget, CgspeedFilesGiveAPlausibleBodyOnTheFloor) {
  const BodyModel model = humanModel();
  for (const char* file :
       {"cmu_104_02_walk.bvh", "cmu_16_20_walk_turn.bvh", "cmu_111_23_run.bvh"}) {
    REQUIRE_SHARED_MOTION(file);
    const Bvh bvh = loadBvh(kMotionDir + file);
    const BodyModel fitted = fitModelToBvh(model, bvh.skeleton);
    KinematicsData data(fitted);
    forwardKinematics(fitted, data, fitted.neutralPose());
    std::vector<Eigen::Vector3d> p = pointPositions(fitted, data);
    auto at = [&](const char* point) { return p[fitted.pointIndex(point)]; };
    const double hip_height = 0.5 * (at("l_hip").z() + at("r_hip").z());
    EXPECT_GT(hip_height, 0.8) << file;
    EXPECT_LT(hip_height, 1.1) << file;

    const RetargetResult result = retargetBvh(fitted, bvh.skeleton, bvh.motion, 25, 50);
    std::vector<double> lowest;
    for (std::size_t k = 0; k < result.motion.size(); ++k) {
      forwardKinematics(fitted, data, result.motion[k]);
      p = pointPositions(fitted, data);
      lowest.push_back(
          std::min({at("l_ankle").z(), at("r_ankle").z(), at("l_toe").z(), at("r_toe").z()}));
      if (k == 0) {
        // Arms down in the motion; in the T-pose the wrists are at the shoulders' height.
        EXPECT_LT(at("l_wrist").z(), at("l_shoulder").z() - 0.3) << file;
        EXPECT_LT(at("r_wrist").z(), at("r_shoulder").z() - 0.3) << file;
        EXPECT_LT(*std::max_element(result.residual_mm[0].begin(), result.residual_mm[0].end()), 75)
            << file;
      }
    }
    std::sort(lowest.begin(), lowest.end());
    std::cout << file << ": hip height " << hip_height << " m, lowest foot point from "
              << lowest.front() << " to " << lowest.back() << " m\n";
    EXPECT_GT(lowest.front(), -0.05) << file;           // never under the floor
    EXPECT_LT(lowest[lowest.size() / 2], 0.1) << file;  // a foot on it
  }
}

TEST(Retarget, IkRecoversAKnownPose) {
  const BodyModel model = humanModel();
  std::mt19937 rng(7);
  KinematicsData data(model);
  for (int trial = 0; trial < 5; ++trial) {
    // A pose well inside the limits, so it is the only one matching its points.
    Eigen::VectorXd truth = model.neutralPose();
    for (std::size_t d = 0; d < model.dofs.size(); ++d) {
      const Dof& dof = model.dofs[d];
      const double range = std::min(dof.max - dof.min, dof.type == DofType::kRotation ? 1.2 : 1.0);
      const double centre = 0.5 * (dof.min + dof.max);
      std::uniform_real_distribution<double> u(centre - 0.3 * range, centre + 0.3 * range);
      truth[d] = u(rng);
    }
    // Elbows bent enough to fix the arm twists.
    truth[model.dofIndex("l_elbow_flex")] = truth[model.dofIndex("r_elbow_flex")] = 0.8;
    truth[model.dofIndex("root_yaw")] = 0.5;
    forwardKinematics(model, data, truth);
    const std::vector<Eigen::Vector3d> targets = pointPositions(model, data);

    // From a different start: every joint DOF 0.3 rad off, the root 20 cm away.
    Eigen::VectorXd start = truth;
    for (std::size_t d = 0; d < model.dofs.size(); ++d)
      start[d] += model.dofs[d].type == DofType::kRotation ? 0.3 : 0.2;
    IkOptions options;
    options.prior_weight = 0;  // nothing to be pulled toward: the points decide alone
    options.max_iterations = 500;
    const IkResult ik = fitPoseToPoints(model, targets, start, start, options);
    EXPECT_LT(ik.rms_error, 1e-4) << "trial " << trial;
    for (std::size_t d = 0; d < model.dofs.size(); ++d) {
      // The head's two points lie on its turning axis: the points cannot tell its turn.
      if (model.dofs[d].name == "neck_turn") continue;
      EXPECT_NEAR(ik.q[d], truth[d], 1e-3) << model.dofs[d].name << ", trial " << trial;
    }
  }
}

TEST(Retarget, IkStaysInsideTheLimits) {
  const BodyModel model = humanModel();
  KinematicsData data(model);
  Eigen::VectorXd pose = model.neutralPose();
  forwardKinematics(model, data, pose);
  std::vector<Eigen::Vector3d> targets = pointPositions(model, data);
  // Knees pulled forward: a knee bending the wrong way would fit them better.
  targets[model.pointIndex("l_knee")].y() += 0.1;
  targets[model.pointIndex("l_ankle")].y() += 0.25;
  const IkResult ik = fitPoseToPoints(model, targets, pose, pose);
  for (std::size_t d = 0; d < model.dofs.size(); ++d) {
    EXPECT_GE(ik.q[d], model.dofs[d].min) << model.dofs[d].name;
    EXPECT_LE(ik.q[d], model.dofs[d].max) << model.dofs[d].name;
  }
}

// Measured (31 DOFs, 25 Hz): walk mean 7.8 mm, max 50.4 mm (a knee bent 125 deg with the foot
// swung out, which the model's hinge knee and 2-DOF ankle cannot copy); hop mean 7.0 mm, max
// 32.8 mm. Without the warm start (every frame from the initial guess) the means barely change
// (8.4, 7.9 mm) but limbs land in wrong branches: max 337 mm and 283 mm, so the max bound is the
// one that catches a broken IK. An IK without limits fits slightly better and fails the limit
// check. The common CMU release's files (cgspeed naming, CMU units), mean / max: walk 5.7 / 20.6
// mm, walk with a turn 6.5 / 21.0 mm, run 9.1 / 30.1 mm.
struct MotionCase {
  const char* name;
  const char* file;
  double mean_mm;  // bound on the mean residual over frames and points
  double max_mm;   // bound on the largest residual of any point in any frame
};

void PrintTo(const MotionCase& c, std::ostream* os) { *os << c.file; }

class RetargetMotion : public ::testing::TestWithParam<MotionCase> {};

TEST_P(RetargetMotion, FollowsTheSubjectWithinLimits) {
  const MotionCase& c = GetParam();
  REQUIRE_SHARED_MOTION(c.file);
  const BodyModel model = humanModel();
  const Bvh bvh = loadBvh(kMotionDir + c.file);
  const BodyModel fitted = fitModelToBvh(model, bvh.skeleton);
  const RetargetResult result = retargetBvh(fitted, bvh.skeleton, bvh.motion, 25);
  const int expected =
      resampledFrameCount(static_cast<int>(bvh.motion.frames.size()), bvh.motion.frame_time, 25);
  ASSERT_EQ(static_cast<int>(result.motion.size()), expected);
  ASSERT_EQ(result.residual_mm.size(), result.motion.size());

  double sum = 0, worst = 0;
  std::size_t count = 0;
  for (const std::vector<double>& frame : result.residual_mm) {
    for (double r : frame) {
      sum += r;
      worst = std::max(worst, r);
      ++count;
    }
  }
  const double mean = sum / count;
  std::cout << c.file << ": mean residual " << mean << " mm, max " << worst << " mm, "
            << result.speed_excess.size() << " DOFs over their speed limit\n";
  EXPECT_LT(mean, c.mean_mm);
  EXPECT_LT(worst, c.max_mm);

  for (const Eigen::VectorXd& q : result.motion) {
    for (std::size_t d = 0; d < fitted.dofs.size(); ++d) {
      ASSERT_GE(q[d], fitted.dofs[d].min) << fitted.dofs[d].name;
      ASSERT_LE(q[d], fitted.dofs[d].max) << fitted.dofs[d].name;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Cmu, RetargetMotion,
                         ::testing::Values(MotionCase{"Walk", "cmu_131_01_walk.bvh", 10, 75},
                                           MotionCase{"Hop", "cmu_131_03_hop.bvh", 10, 75},
                                           MotionCase{"CgspeedWalk", "cmu_104_02_walk.bvh", 12, 60},
                                           MotionCase{"CgspeedWalkTurn", "cmu_16_20_walk_turn.bvh",
                                                      12, 60},
                                           MotionCase{"CgspeedRun", "cmu_111_23_run.bvh", 12, 60}),
                         [](const ::testing::TestParamInfo<MotionCase>& param_info) {
                           return std::string(param_info.param.name);
                         });

}  // namespace
}  // namespace mocap
