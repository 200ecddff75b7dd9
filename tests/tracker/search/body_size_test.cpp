// Fitting the body to a subject: proportions change the bones they name and keep the feet on the
// floor; a subject of another build standing in the fit pose is found and its build recovered
// from two cameras; no subject, or a model without a fit pose, is said so; bounds that leave a
// proportion no range are refused; a fit stops when asked.
#include "tracker/search/body_size.h"

#include <functional>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/model/builtin_models.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/retarget.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;
using testing_support::silhouettes;

std::vector<Eigen::Vector3d> standingPoints(const BodyModel& model) {
  KinematicsData kin(model);
  forwardKinematics(model, kin, model.neutralPose());
  return pointPositions(model, kin);
}

double distance(const BodyModel& model, const std::vector<Eigen::Vector3d>& points, const char* a,
                const char* b) {
  return (points[model.pointIndex(a)] - points[model.pointIndex(b)]).norm();
}

TEST(BodyProportions, EachChangesTheBonesItNamesAndTheFeetStayOnTheFloor) {
  const BodyModel human = builtinHumanModel();
  const auto before = standingPoints(human);
  // All ones: the same body.
  const auto same = standingPoints(proportionedBodyModel(human, {}));
  for (std::size_t p = 0; p < before.size(); ++p) EXPECT_LT((same[p] - before[p]).norm(), 1e-9);

  BodyProportions build;
  build.legs = 0.9;
  build.arms = 0.8;
  build.width = 1.2;
  build.trunk_girth = 1.1;
  build.arm_girth = 0.9;
  build.leg_girth = 1.2;
  build.thigh_end_girth = 2;
  const BodyModel fitted = proportionedBodyModel(human, build);
  const auto after = standingPoints(fitted);
  for (const char* side : {"l_", "r_"}) {
    const auto bone = [&](const char* a, const char* b) {
      const std::string from = std::string(side) + a, to = std::string(side) + b;
      return distance(fitted, after, from.c_str(), to.c_str()) /
             distance(human, before, from.c_str(), to.c_str());
    };
    EXPECT_NEAR(bone("hip", "knee"), 0.9, 1e-9);
    EXPECT_NEAR(bone("knee", "ankle"), 0.9, 1e-9);
    EXPECT_NEAR(bone("shoulder", "elbow"), 0.8, 1e-9);
    EXPECT_NEAR(bone("elbow", "wrist"), 0.8, 1e-9);
  }
  EXPECT_NEAR(distance(fitted, after, "l_hip", "r_hip") / distance(human, before, "l_hip", "r_hip"),
              1.2, 1e-9);
  EXPECT_NEAR(distance(fitted, after, "pelvis", "neck"), distance(human, before, "pelvis", "neck"),
              1e-9);  // the trunk as it was
  // The ankles stand where they stood, so the shorter legs lower the pelvis.
  EXPECT_NEAR(after[human.pointIndex("l_ankle")].z(), before[human.pointIndex("l_ankle")].z(),
              1e-9);
  EXPECT_LT(after[human.pointIndex("pelvis")].z(), before[human.pointIndex("pelvis")].z() - 0.05);
  // Each part's girth on its own segments, down to the feet.
  const auto radius = [](const BodyModel& body, const char* segment) {
    const Shape& shape = body.segments[body.segmentIndex(segment)].shape;
    return shape.type == ShapeType::kEllipsoid ? shape.radii.y() : shape.radius_start;
  };
  for (const auto& [segment, girth] :
       std::vector<std::pair<const char*, double>>{{"pelvis", 1.1},
                                                   {"chest", 1.1},
                                                   {"head", 1.1},
                                                   {"r_upper_arm", 0.9},
                                                   {"l_forearm", 0.9},
                                                   {"l_thigh", 1.2},
                                                   {"r_shin", 1.2},
                                                   {"r_foot", 1.2}}) {
    SCOPED_TRACE(segment);
    EXPECT_NEAR(radius(fitted, segment), girth * radius(human, segment), 1e-12);
  }
  // The thighs' end girth is theirs at the knee alone.
  const auto knee_end = [](const BodyModel& body, const char* segment) {
    return body.segments[body.segmentIndex(segment)].shape.radius_end;
  };
  for (const char* thigh : {"l_thigh", "r_thigh"})
    EXPECT_NEAR(knee_end(fitted, thigh), 2 * knee_end(human, thigh), 1e-12) << thigh;
  EXPECT_NEAR(knee_end(fitted, "l_shin"), 1.2 * knee_end(human, "l_shin"), 1e-12);
}

TEST(BodyFit, RecoversTheBuildOfASubjectStandingInTheFitPose) {
  const BodyModel human = builtinHumanModel();
  ASSERT_TRUE(human.fit_pose);
  // A smaller subject of another build, in the A-pose away from the origin, turned.
  BodyProportions truth;
  truth.legs = 0.92;
  truth.arms = 0.82;
  truth.trunk = 0.9;
  truth.head = 0.85;
  truth.width = 0.9;
  truth.trunk_girth = 0.95;
  truth.arm_girth = 1.1;
  truth.leg_girth = 0.9;
  truth.thigh_end_girth = 2.5;  // as a skirt's hem
  const BodyModel subject = proportionedBodyModel(human, truth);
  Eigen::VectorXd standing = human.stancePose(*human.fit_pose);
  standing[human.dofIndex("root_tx")] = 0.4;
  standing[human.dofIndex("root_ty")] = -0.3;
  standing[human.dofIndex("root_yaw")] = 0.6;
  const Rig rig = labRig(2, human, Motion{standing});
  // Turning in place through a quarter turn, as the subject is asked to.
  std::vector<std::vector<SilhouetteMask>> frames;
  for (int k = 0; k < 3; ++k) {
    Eigen::VectorXd turned = standing;
    turned[human.dofIndex("root_yaw")] += k * M_PI / 4;
    frames.push_back(silhouettes(subject, rig, turned));
  }

  std::string why;
  const std::optional<BodyFit> fit =
      fitBodyInPose(human, rig, frames, LikelihoodParams{}, {}, &why);
  ASSERT_TRUE(fit) << why;
  for (int k = 0; k < BodyProportions::kCount; ++k) {
    if (k == BodyProportions::kThighEndGirth) continue;                  // below
    if (std::string(BodyProportions::name(k)) == "arm_girth") continue;  // below
    SCOPED_TRACE(BodyProportions::name(k));
    EXPECT_NEAR(fit->proportions[k], truth[k], 0.05) << fit->proportions[k];
  }
  // The arms are fitted apart from the trunk, thicker as the subject's are. Not to 5 %: the 8-point
  // outline draws a cone 3 % narrow to 5 % wide by its orientation, so arms this thin come out
  // thinner (1.04 here; lab log, "the girth of each part").
  EXPECT_GT(fit->proportions.arm_girth, fit->proportions.trunk_girth + 0.05);
  EXPECT_LT(fit->proportions.arm_girth, truth.arm_girth + 0.05);
  // The thighs' end girth, here a garment's, to 10 %.
  EXPECT_NEAR(fit->proportions.thigh_end_girth, truth.thigh_end_girth, 0.25);
  // The fitted body explains the silhouettes better than the best of the uniform scales did.
  const auto scale =
      std::max_element(fit->scale_log_likelihoods.begin(), fit->scale_log_likelihoods.end());
  EXPECT_GT(fit->log_likelihood, *scale);
  ASSERT_EQ(fit->poses.size(), 3u);
  EXPECT_GT(fit->evaluations, 0);
}

TEST(BodyFit, NoSubjectOrNoFitPoseIsSaid) {
  const BodyModel human = builtinHumanModel();
  const Rig rig = labRig(2, human, Motion{human.neutralPose()});
  std::vector<std::vector<SilhouetteMask>> empty(1);
  for (const CameraModel& camera : rig)
    empty[0].emplace_back(cv::Mat::zeros(camera.height, camera.width, CV_8UC1));
  std::string why;
  EXPECT_FALSE(fitBodyInPose(human, rig, empty, LikelihoodParams{}, {}, &why));
  EXPECT_THAT(why, HasSubstr("camera"));

  BodyModel without = human;
  without.fit_pose.reset();
  try {
    fitBodyInPose(without, rig, empty, LikelihoodParams{});
    FAIL() << "fitted without a fit pose";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("has no fit_pose"));
  }
  EXPECT_THROW(fitBodyToSubject(human, rig, empty, {}, LikelihoodParams{}), std::invalid_argument);
}

TEST(BodyFit, ProportionBoundsThatLeaveNoRangeAreRefused) {
  const BodyModel human = builtinHumanModel();
  const Eigen::VectorXd standing = human.stancePose(*human.fit_pose);
  const Rig rig = labRig(2, human, Motion{standing});
  const std::vector<std::vector<SilhouetteMask>> frames = {silhouettes(human, rig, standing)};
  for (const auto& spoil : std::vector<std::function<void(BodyFitOptions&)>>{
           [](BodyFitOptions& o) { o.max_factor = 0.5; },
           [](BodyFitOptions& o) { o.max_thigh_end_girth = 0.5; },
           [](BodyFitOptions& o) { o.min_factor = 0; },
           [](BodyFitOptions& o) { o.thigh_end_step = 0; },
           [](BodyFitOptions& o) { o.finest_step = -1; }}) {
    BodyFitOptions options;
    spoil(options);
    try {
      fitBodyToSubject(human, rig, frames, {standing}, LikelihoodParams{}, options);
      ADD_FAILURE() << "fitted with bounds that leave no range";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("body proportions: expected 0 < min_factor"));
    }
  }
}

TEST(BodyFit, StopsWhenAsked) {
  const BodyModel human = builtinHumanModel();
  const Eigen::VectorXd standing = human.stancePose(*human.fit_pose);
  const Rig rig = labRig(2, human, Motion{standing});
  const std::vector<std::vector<SilhouetteMask>> frames = {silhouettes(human, rig, standing)};
  int asked = 0;
  BodyFitOptions options;
  options.should_stop = [&] { return ++asked > 3; };  // after three frame-set searches
  EXPECT_THROW(fitBodyInPose(human, rig, frames, LikelihoodParams{}, options), BodyFitStopped);
  EXPECT_EQ(asked, 4);
}

TEST(BodyFit, TheFitPoseStandsWhereAPoseStandsAndFacesItsWay) {
  const BodyModel human = builtinHumanModel();
  const Eigen::VectorXd placed =
      Eigen::VectorXd::Constant(static_cast<Eigen::Index>(human.dofs.size()), 0.3);
  const FitStance standing = fitPoseAt(human, placed);
  const Eigen::VectorXd fit_pose = human.stancePose(*human.fit_pose);
  EXPECT_EQ(standing.turn_dof, human.dofIndex("root_yaw"));
  for (std::size_t d = 0; d < human.dofs.size(); ++d) {
    const std::string& name = human.dofs[d].name;
    const bool taken =
        name == "root_tx" || name == "root_ty" || name == "root_tz" || name == "root_yaw";
    const auto i = static_cast<Eigen::Index>(d);
    EXPECT_EQ(standing.pose[i], taken ? 0.3 : fit_pose[i]) << name;
  }
  EXPECT_THROW(fitPoseAt(builtinHandModel(), Eigen::VectorXd::Zero(15)), std::invalid_argument);
}

}  // namespace
}  // namespace mocap
