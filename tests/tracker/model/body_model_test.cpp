// Body model YAML loading: the built-in hand, errors that name the file, line and field, and the
// YAML a session stores the model in, read back to the same model.
#include "tracker/model/body_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "tracker/model/builtin_models.h"
#include "tracker/model/kinematics.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;

constexpr const char* kTwoSegments = R"(
name: arm
segments:
  - name: upper
    offset: [0, 0, 1]
    dofs: [{name: shoulder, axis: [0, 2, 0], min: -90, max: 90, max_speed: 10}]
    shape: {type: cone, axis: [1, 0, 0], length: 0.3, radius_start: 0.05, radius_end: 0.04}
    points: [{name: shoulder_point}]
  - name: lower
    parent: upper
    offset: [0.3, 0, 0]
    dofs:
      - {name: slide, type: translation, axis: [1, 0, 0], min: 0, max: 0.1, max_speed: 0.01}
    shape: {type: ellipsoid, center: [0.1, 0, 0], radii: [0.1, 0.03, 0.03]}
    points: [{name: hand, at: [0.2, 0, 0]}]
)";

TEST(BodyModel, ParsesSegmentsDofsShapesAndPoints) {
  const BodyModel m = parseBodyModel(kTwoSegments, "arm.yaml");
  ASSERT_EQ(m.segments.size(), 2u);
  ASSERT_EQ(m.dofs.size(), 2u);
  EXPECT_EQ(m.segments[1].parent, 0);
  EXPECT_EQ(m.dofs[0].type, DofType::kRotation);
  EXPECT_NEAR(m.dofs[0].max, M_PI / 2, 1e-12);  // degrees at the edge, radians inside
  EXPECT_NEAR(m.dofs[0].max_speed, 10 * M_PI / 180, 1e-12);
  EXPECT_TRUE(m.dofs[0].axis.isApprox(Eigen::Vector3d::UnitY()));  // normalized
  EXPECT_EQ(m.dofs[1].type, DofType::kTranslation);
  EXPECT_DOUBLE_EQ(m.dofs[1].max, 0.1);  // metres stay metres
  EXPECT_EQ(m.dofs[1].segment, 1);
  EXPECT_EQ(m.segments[0].shape.type, ShapeType::kTruncatedCone);
  EXPECT_EQ(m.segments[1].shape.type, ShapeType::kEllipsoid);
  EXPECT_EQ(m.pointIndex("hand"), 1);
  EXPECT_TRUE(m.points[1].local.isApprox(Eigen::Vector3d(0.2, 0, 0)));
  EXPECT_FALSE(m.isStatic(0));
}

TEST(BodyModel, BuiltInHandHasFifteenDofsInTopologicalOrder) {
  const BodyModel m = loadBodyModel(std::string(MOCAP_SOURCE_DIR) + "/tracker/models/hand.yaml");
  EXPECT_EQ(m.dofs.size(), 15u);
  EXPECT_EQ(m.segments.size(), 16u);
  EXPECT_TRUE(m.isStatic(0));
  for (std::size_t s = 1; s < m.segments.size(); ++s) EXPECT_LT(m.segments[s].parent, int(s));
  EXPECT_GE(m.pointIndex("index_tip"), 0);
}

std::string errorOf(const std::string& yaml) {
  try {
    parseBodyModel(yaml, "bad.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(BodyModel, ErrorsNameTheFileLineAndField) {
  // Each case edits the valid model in one place: the text replaced, its replacement, the error.
  const struct {
    const char* from;
    const char* to;
    const char* error;
  } cases[] = {
      {"max: 90", "max: ninety",
       "bad.yaml:6: segments[0] (upper).dofs[0].max: expected a number, got 'ninety'"},
      {"parent: upper", "parent: nobody", "segments[1] (lower).parent: unknown segment 'nobody'"},
      {"length: 0.3, ", "", "segments[0] (upper).shape.length: missing"},
      {"type: cone", "type: cube", "unknown shape 'cube'"},
      {"min: -90, max: 90", "min: 90, max: -90", "(upper).dofs[0]: min is greater than max"},
      {"name: arm", "name: arm\nkind: horse",
       "bad.yaml:3: kind: expected person or other, got 'horse'"},
      {"name: arm", "name: arm\nfacing_twists: [shoulder, slide]",
       "bad.yaml:3: facing_twists[1]: 'slide' is not a rotation"},
      {"name: arm", "name: arm\nfacing_twists: [elbow]", "facing_twists[0]: unknown DOF 'elbow'"},
      {"name: arm", "name: arm\ngait_dofs: [shoulder, slide, shoulder]",
       "bad.yaml:3: gait_dofs[2]: 'shoulder' is listed twice"},
      // A misspelt optional key is named, not ignored.
      {"name: arm", "name: arm\nkindd: person",
       "bad.yaml:3: (top).kindd: unknown key (known: name, kind, frame_rate, gait_dofs, "
       "facing_twists, feet, stances, fit_pose, segments)"},
      {"name: arm", "name: arm\nfit_pose: {shoulder: 100}",
       "bad.yaml:3: fit_pose.shoulder: outside the DOF's limits"},
      {"name: arm", "name: arm\nfit_pose: [shoulder]",
       "bad.yaml:3: fit_pose: expected a map of DOF values"},
      {"name: arm", "name: arm\nstances: [{name: up, elbow: 10}]",
       "bad.yaml:3: stances[0].elbow: unknown DOF"},
      {"name: arm", "name: arm\nstances: [{name: up, shoulder: 100}]",
       "bad.yaml:3: stances[0].shoulder: outside the DOF's limits"},
      {"name: arm", "name: arm\nstances: [{shoulder: 10}]", "stances[0].name: missing"},
      {"name: arm", "name: arm\nfeet: [lower]",
       "bad.yaml:3: feet[0]: 'lower' needs a parent and a grandparent segment"},
      {"name: arm", "name: arm\nfeet: [paw]", "feet[0]: unknown segment 'paw'"},
      {"name: arm", "name: arm\nframe_rate: 0", "bad.yaml:3: frame_rate: must be positive, got 0"},
      {"name: arm", "name: arm\nframe_rate: fast", "frame_rate: expected a number, got 'fast'"},
      {"offset: [0, 0, 1]", "ofset: [0, 0, 1]",
       "bad.yaml:5: segments[0] (upper).ofset: unknown key"},
      {"radius_end", "radius_ed", "segments[0] (upper).shape.radius_ed: unknown key"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.to);
    std::string bad = kTwoSegments;
    const std::size_t at = bad.find(c.from);
    ASSERT_NE(at, std::string::npos);
    bad.replace(at, std::string(c.from).size(), c.to);
    EXPECT_THAT(errorOf(bad), HasSubstr(c.error));
  }
  // Facing twists add up signed by their axes, so each must turn about the first's axis or against
  // it.
  const std::string translation = "type: translation, axis: [1, 0, 0], min: 0, max: 0.1";
  std::string crossed = kTwoSegments;
  crossed.replace(crossed.find(translation), translation.size(),
                  "axis: [1, 0, 0], min: 0, max: 10");
  crossed.replace(crossed.find("name: arm"), 9, "name: arm\nfacing_twists: [shoulder, slide]");
  EXPECT_THAT(errorOf(crossed),
              HasSubstr("bad.yaml:3: facing_twists[1]: 'slide' turns about an axis "
                        "neither along nor against 'shoulder''s"));
  EXPECT_THAT(errorOf("segments: [ {name: a"), HasSubstr("bad.yaml:1: not valid YAML"));
  EXPECT_THAT(errorOf("name: x"), HasSubstr("(top).segments: missing"));
}

TEST(BodyModel, MissingFileIsNamed) {
  EXPECT_THROW(
      {
        try {
          loadBodyModel("/nonexistent/model.yaml");
        } catch (const std::runtime_error& e) {
          EXPECT_THAT(e.what(), HasSubstr("/nonexistent/model.yaml"));
          throw;
        }
      },
      std::runtime_error);
}

TEST(BodyModel, StancesSetTheirDofsInTheFilesUnitsAndTheRestNeutral) {
  std::string yaml = kTwoSegments;
  yaml.replace(
      yaml.find("name: arm"), 9,
      "name: arm\nstances: [{name: reach, shoulder: 45, slide: 0.05}, {name: tucked, slide: 0.1}]");
  const BodyModel m = parseBodyModel(yaml, "arm.yaml");
  ASSERT_EQ(m.stances.size(), 2u);
  EXPECT_EQ(m.stances[1].name, "tucked");
  const Eigen::VectorXd reach = m.stancePose(m.stances[0]), tucked = m.stancePose(m.stances[1]);
  EXPECT_NEAR(reach[0], M_PI / 4, 1e-12);  // degrees in the file
  EXPECT_DOUBLE_EQ(reach[1], 0.05);        // metres
  EXPECT_DOUBLE_EQ(tucked[0], 0.0);        // unlisted: neutral
  // A frozen DOF holds its frozen value in every stance.
  const BodyModel frozen = freezeAllBut(m, {"slide"}, Eigen::Vector2d(0.2, 0));
  EXPECT_DOUBLE_EQ(frozen.stancePose(frozen.stances[0])[0], 0.2);
  // The human is tried mid-stride both ways and crouching.
  const BodyModel human = builtinHumanModel();
  ASSERT_EQ(human.stances.size(), 3u);
  EXPECT_EQ(human.stances[2].name, "crouch");
  EXPECT_NEAR(human.stancePose(human.stances[2])[human.dofIndex("l_knee_flex")], M_PI / 2, 1e-12);
  // Its body is fitted to a subject standing with the arms out (an A-pose), which is no stance.
  ASSERT_TRUE(human.fit_pose.has_value());
  EXPECT_NEAR(human.stancePose(*human.fit_pose)[human.dofIndex("r_shoulder_abd")], M_PI / 4, 1e-12);
  EXPECT_FALSE(m.fit_pose.has_value());
}

TEST(BodyModel, HumanModelHas31DofsAnd19JointsAndAGaitSubset) {
  const BodyModel m = loadBodyModel(std::string(MOCAP_SOURCE_DIR) + "/tracker/models/human.yaml");
  EXPECT_TRUE(m.person);
  EXPECT_EQ(m.facing_twists, (std::vector<std::string>{"r_hip_twist", "l_hip_twist"}));
  EXPECT_EQ(m.feet, (std::vector<std::string>{"r_foot", "l_foot"}));
  EXPECT_FALSE(builtinHandModel().person);
  EXPECT_FALSE(parseBodyModel(kTwoSegments, "arm.yaml").person);
  EXPECT_EQ(m.dofs.size(), 31u);
  EXPECT_EQ(m.points.size(), 19u);
  EXPECT_EQ(m.gait_dofs.size(), 17u);
  // Four branches leave the trunk: the legs from the pelvis, head and arms from the chest.
  const int pelvis = m.segmentIndex("pelvis"), chest = m.segmentIndex("chest");
  int from_trunk = 0;
  for (const Segment& s : m.segments) from_trunk += (s.parent == pelvis || s.parent == chest);
  EXPECT_EQ(from_trunk, 6);  // chest, 2 thighs, head, 2 upper arms

  const BodyModel gait = freezeAllBut(m, m.gait_dofs, m.neutralPose());
  int free = 0;
  for (const Dof& d : gait.dofs) free += d.isFree();
  EXPECT_EQ(free, 17);
  EXPECT_FALSE(gait.isStatic(m.segmentIndex("l_forearm")));  // still moved by the trunk
  EXPECT_THROW(freezeAllBut(m, {"no_such_dof"}, m.neutralPose()), std::invalid_argument);
}

TEST(BodyModel, SpeedLimitsArePerFrameAtTheModelsFrameRate) {
  const BodyModel arm = parseBodyModel(kTwoSegments, "arm.yaml");
  EXPECT_EQ(arm.frame_rate, 25);  // the paper's rate, when the file does not say
  EXPECT_EQ(builtinHumanModel().frame_rate, 25);
  EXPECT_EQ(parseBodyModel(std::string(kTwoSegments) + "frame_rate: 50\n", "arm.yaml").frame_rate,
            50);

  // At 50 Hz a frame lasts half as long, so each DOF may move half as far in one; rotations and
  // translations alike, and nothing else changes.
  const BodyModel fast = atFrameRate(arm, 50);
  EXPECT_EQ(fast.frame_rate, 50);
  EXPECT_NEAR(fast.dofs[0].max_speed, 5 * M_PI / 180, 1e-15);
  EXPECT_NEAR(fast.dofs[1].max_speed, 0.005, 1e-15);
  EXPECT_EQ(fast.dofs[0].max, arm.dofs[0].max);
  EXPECT_EQ(fast.segments[0].shape.length, arm.segments[0].shape.length);
  // Rescaling composes: 50 Hz then 12.5 Hz is 12.5 Hz from the file's 25.
  EXPECT_NEAR(atFrameRate(fast, 12.5).dofs[0].max_speed, 20 * M_PI / 180, 1e-15);
  EXPECT_THROW(atFrameRate(arm, 0), std::invalid_argument);
  EXPECT_THROW(atFrameRate(arm, NAN), std::invalid_argument);
}

TEST(BodyModel, AScaledBodyIsTheSameBodyLargerStandingOnTheSameFloor) {
  const BodyModel human = builtinHumanModel();
  const BodyModel tall = scaledBodyModel(human, 1.1);
  // Any pose: the same angles put every point 1.1 times as far from where the root stands, and the
  // root's displacement is the same metres on both (a translation DOF is not a length of the body).
  Eigen::VectorXd q = human.neutralPose();
  for (std::size_t d = 0; d < human.dofs.size(); ++d)
    q[static_cast<long>(d)] = human.dofs[d].min + 0.37 * (human.dofs[d].max - human.dofs[d].min);
  const Eigen::Vector3d moved(0.4, -0.2, 0.1);
  q[human.dofIndex("root_tx")] = moved.x();
  q[human.dofIndex("root_ty")] = moved.y();
  q[human.dofIndex("root_tz")] = moved.z();
  KinematicsData kin(human), tall_kin(tall);
  forwardKinematics(human, kin, q);
  forwardKinematics(tall, tall_kin, q);
  const auto points = pointPositions(human, kin), tall_points = pointPositions(tall, tall_kin);
  ASSERT_EQ(points.size(), tall_points.size());
  for (std::size_t p = 0; p < points.size(); ++p) {
    SCOPED_TRACE(human.points[p].name);
    EXPECT_LT(((tall_points[p] - moved) - 1.1 * (points[p] - moved)).norm(), 1e-12);
  }
  // Standing, the feet stay on the floor: the lowest point is 1.1 times as high (both near zero).
  forwardKinematics(human, kin, human.neutralPose());
  forwardKinematics(tall, tall_kin, tall.neutralPose());
  const auto lowest = [](const std::vector<Eigen::Vector3d>& ps) {
    double z = INFINITY;
    for (const Eigen::Vector3d& p : ps) z = std::min(z, p.z());
    return z;
  };
  EXPECT_NEAR(lowest(pointPositions(tall, tall_kin)), 1.1 * lowest(pointPositions(human, kin)),
              1e-12);
  EXPECT_NEAR(tall.segments[1].shape.radii.x(), 1.1 * human.segments[1].shape.radii.x(), 1e-15);
  EXPECT_EQ(tall.dofs[0].max, human.dofs[0].max);
  EXPECT_EQ(tall.dofs[0].max_speed, human.dofs[0].max_speed);
  EXPECT_THROW(scaledBodyModel(human, 0), std::invalid_argument);
  EXPECT_THROW(scaledBodyModel(human, NAN), std::invalid_argument);
}

void expectSameModel(const BodyModel& a, const BodyModel& b) {
  constexpr double kTolerance = 1e-12;  // degrees and back may move the last bit of an angle
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.person, b.person);
  EXPECT_EQ(a.frame_rate, b.frame_rate);
  EXPECT_EQ(a.gait_dofs, b.gait_dofs);
  EXPECT_EQ(a.facing_twists, b.facing_twists);
  EXPECT_EQ(a.feet, b.feet);
  ASSERT_EQ(a.stances.size(), b.stances.size());
  for (std::size_t k = 0; k < a.stances.size(); ++k) {
    EXPECT_EQ(a.stances[k].name, b.stances[k].name);
    EXPECT_LT((a.stancePose(a.stances[k]) - b.stancePose(b.stances[k])).norm(), kTolerance);
  }
  ASSERT_EQ(a.fit_pose.has_value(), b.fit_pose.has_value());
  if (a.fit_pose) {
    EXPECT_LT((a.stancePose(*a.fit_pose) - b.stancePose(*b.fit_pose)).norm(), kTolerance);
  }
  ASSERT_EQ(a.segments.size(), b.segments.size());
  for (std::size_t s = 0; s < a.segments.size(); ++s) {
    const Segment &x = a.segments[s], &y = b.segments[s];
    SCOPED_TRACE(x.name);
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.parent, y.parent);
    EXPECT_EQ(x.dofs, y.dofs);
    EXPECT_LT((x.offset - y.offset).norm(), kTolerance);
    EXPECT_EQ(x.shape.type, y.shape.type);
    EXPECT_NEAR(x.shape.length, y.shape.length, kTolerance);
    EXPECT_NEAR(x.shape.radius_start, y.shape.radius_start, kTolerance);
    EXPECT_NEAR(x.shape.radius_end, y.shape.radius_end, kTolerance);
    EXPECT_LT((x.shape.axis - y.shape.axis).norm(), kTolerance);
    EXPECT_LT((x.shape.center - y.shape.center).norm(), kTolerance);
    EXPECT_LT((x.shape.radii - y.shape.radii).norm(), kTolerance);
  }
  ASSERT_EQ(a.dofs.size(), b.dofs.size());
  for (std::size_t d = 0; d < a.dofs.size(); ++d) {
    const Dof &x = a.dofs[d], &y = b.dofs[d];
    SCOPED_TRACE(x.name);
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.type, y.type);
    EXPECT_EQ(x.segment, y.segment);
    EXPECT_LT((x.axis - y.axis).norm(), kTolerance);
    EXPECT_NEAR(x.min, y.min, kTolerance);
    EXPECT_NEAR(x.max, y.max, kTolerance);
    EXPECT_NEAR(x.max_speed, y.max_speed, kTolerance);
    EXPECT_EQ(x.isFree(), y.isFree());
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t p = 0; p < a.points.size(); ++p) {
    EXPECT_EQ(a.points[p].name, b.points[p].name);
    EXPECT_EQ(a.points[p].segment, b.points[p].segment);
    EXPECT_LT((a.points[p].local - b.points[p].local).norm(), kTolerance);
  }
}

TEST(BodyModel, FormattedYamlReadsBackAsTheSameModel) {
  BodyModel human = builtinHumanModel();
  human.segments[human.segmentIndex("l_shin")].shape.length *= 1.1;  // a fitted subject
  Eigen::VectorXd pose = human.neutralPose();
  pose[human.dofIndex("l_elbow_flex")] = 0.3;  // not a gait DOF: frozen at 0.3 (min == max)
  const BodyModel gait = freezeAllBut(human, human.gait_dofs, pose);
  for (const BodyModel& model : {builtinHandModel(), human, gait, atFrameRate(human, 30),
                                 parseBodyModel(kTwoSegments, "arm.yaml")}) {
    SCOPED_TRACE(model.name);
    expectSameModel(model, parseBodyModel(formatBodyModel(model), "formatted"));
  }
}

}  // namespace
}  // namespace mocap
