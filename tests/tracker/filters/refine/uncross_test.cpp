// The refinement's uncrossing: the crossed feet's cost is what the geometry says and free up to
// its margin, and the move gives a stride tracked with crossed legs back its own legs.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "tests/tracker/filters/refine/refine_test_support.h"
#include "tracker/filters/refine/legs.h"
#include "tracker/filters/refine/uncross.h"

namespace mocap {
namespace {

using testing_support::pelvisAndLegs;
using testing_support::refineAlone;
using testing_support::silhouettes;
using testing_support::twoCamerasOnTheLegs;

constexpr double kDeg = M_PI / 180;

// Legs that flex, swing sideways and bend at the knee, on hips 0.2 m apart. DOFs: height, then
// the right hip's flex and abduction and knee, then the left's.
BodyModel swingingLegs(const std::string& feet) {
  const std::string leg = R"(
  - name: S_thigh
    parent: pelvis
    offset: [X, 0, -0.05]
    dofs:
      - {name: S_flex, axis: [1, 0, 0], min: -60, max: 120, max_speed: 20}
      - {name: S_abduct, axis: [0, A, 0], min: -45, max: 45, max_speed: 12}
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.05, radius_end: 0.035}
  - name: S_shin
    parent: S_thigh
    offset: [0, 0, -0.42]
    dofs: [{name: S_knee, axis: [-1, 0, 0], min: 0, max: 150, max_speed: 32}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.035, radius_end: 0.025}
  - name: S_foot
    parent: S_shin
    offset: [0, 0, -0.42]
    shape: {type: ellipsoid, center: [0, 0.08, -0.04], radii: [0.05, 0.13, 0.04]}
)";
  const auto side = [&](const std::string& s, const std::string& x, const std::string& a) {
    std::string text = leg;
    const std::vector<std::pair<std::string, std::string>> names = {
        {"S_", s + "_"}, {"X,", x + ","}, {"A,", a + ","}};
    for (const auto& [from, to] : names)
      for (std::size_t at; (at = text.find(from)) != std::string::npos;)
        text.replace(at, from.size(), to);
    return text;
  };
  return parseBodyModel("name: swinging_legs\nfeet: " + feet + R"(
segments:
  - name: pelvis
    offset: [0, 0, 0.9]
    dofs:
      - {name: height, type: translation, axis: [0, 0, 1], min: -0.5, max: 0.5, max_speed: 0.03}
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.14, 0.09, 0.07]}
)" + side("r", "0.1", "-1") +
                            side("l", "-0.1", "1"),
                        "swinging_legs.yaml");
}

Eigen::VectorXd pose(double r_flex, double r_abduct, double r_knee, double l_flex, double l_abduct,
                     double l_knee) {
  Eigen::VectorXd q(7);
  q << 0, r_flex * kDeg, r_abduct * kDeg, r_knee * kDeg, l_flex * kDeg, l_abduct * kDeg,
      l_knee * kDeg;
  return q;
}

double crossingAt(const BodyModel& model, const CrossedLegs& crossed, const Eigen::VectorXd& q) {
  KinematicsData kinematics(model);
  forwardKinematics(model, kinematics, q);
  return crossed.crossing(kinematics);
}

// Straight legs swung in by angles a (right) and b (left) from hips 0.2 m apart put the feet
// 0.84 (sin a + sin b) - 0.2 m past each other, whichever foot the model names first; the cost is
// free up to 0.15 m and quadratic beyond.
TEST(FactoredFilter, CrossedFeetCostWhatTheyCrossBeyondTheMargin) {
  for (const std::string feet : {"[r_foot, l_foot]", "[l_foot, r_foot]"}) {
    SCOPED_TRACE(feet);
    const BodyModel model = swingingLegs(feet);
    const CrossedLegs crossed = findCrossedLegs(model, 10);
    KinematicsData kinematics(model);
    const std::vector<std::pair<double, double>> swings = {{0, 0}, {10, 0}, {15, 10}, {30, 25}};
    for (const auto& [r_in, l_in] : swings) {
      // Abduction's negative is the swing inwards.
      const Eigen::VectorXd q = pose(0, -r_in, 0, 0, -l_in, 0);
      const double expected = 0.84 * (std::sin(r_in * kDeg) + std::sin(l_in * kDeg)) - 0.2;
      forwardKinematics(model, kinematics, q);
      EXPECT_NEAR(crossed.crossing(kinematics), expected, 1e-9);
      const double over = std::max(0.0, expected - CrossedLegs::kFreeCrossing) / CrossedLegs::kUnit;
      EXPECT_NEAR(crossed.cost(kinematics), 10 * over * over, 1e-9);
      EXPECT_EQ(crossed.cost(model, kinematics, q), crossed.cost(kinematics));
    }
    // Standing, and crossed by 0.1 m: free. Crossed by 0.36 m: charged.
    EXPECT_EQ(crossed.cost(model, kinematics, pose(0, 0, 0, 0, 0, 0)), 0);
    EXPECT_EQ(crossed.cost(model, kinematics, pose(0, -15, 0, 0, -5, 0)), 0);
    EXPECT_GT(crossed.cost(model, kinematics, pose(0, -30, 0, 0, -10, 0)), 30);
  }
}

// A body that names no two feet has no legs to uncross, and says so when asked to.
TEST(FactoredFilter, CrossedFeetNeedTwoMatchingLegs) {
  const BodyModel no_feet = pelvisAndLegs();         // legs, but no `feet` named
  EXPECT_EQ(findCrossedLegs(no_feet, 0).weight, 0);  // off: nothing asked of the model
  try {
    findCrossedLegs(no_feet, 10);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("refine_uncross"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("feet"), std::string::npos) << e.what();
  }
}

// A stride tracked with the legs' labels exchanged: the feet where the silhouettes have them, but
// each reached by the other leg, so the legs cross. No step of one leg gets to the other side
// past its twin; the move, which gives each leg the other's foot, gets the stride back.
TEST(FactoredFilter, UncrossingGivesAStrideTrackedCrossedItsOwnLegs) {
  const BodyModel model = swingingLegs("[r_foot, l_foot]");
  const Rig rig = twoCamerasOnTheLegs();
  const Eigen::VectorXd truth = pose(25, 8, 45, -15, 8, 50);
  const std::vector<SilhouetteMask> masks = silhouettes(model, rig, truth);

  // Each leg moved by hip and knee to the other's foot.
  KinematicsData kinematics(model);
  forwardKinematics(model, kinematics, truth);
  LegData data(model);
  Eigen::VectorXd start = truth;
  const std::vector<Leg> legs = findLegs(model);
  ASSERT_EQ(legs.size(), 2u);
  for (const Leg& leg : legs) {
    const Leg& other = legs[&leg == &legs[0] ? 1 : 0];
    moveJointTo(model, data, leg, leg.segment, kinematics.world[other.segment].translation(),
                start);
  }
  KinematicsData placed(model);
  forwardKinematics(model, placed, start);
  for (int f = 0; f < 2; ++f)
    ASSERT_LT((placed.world[legs[f].segment].translation() -
               kinematics.world[legs[1 - f].segment].translation())
                  .norm(),
              0.01)
        << "leg " << f << " does not reach the other's foot";
  const CrossedLegs crossed = findCrossedLegs(model, 10);
  ASSERT_GT(crossingAt(model, crossed, start), 0.3) << "the start does not cross";

  const auto worstAngleError = [&](double uncross) {
    FilterOptions options;
    options.refine.uncross = uncross;
    const Eigen::VectorXd q = refineAlone(model, rig, masks, start, options);
    return (q.tail(6) - truth.tail(6)).cwiseAbs().maxCoeff() / kDeg;
  };
  EXPECT_LT(worstAngleError(10), 2);
  EXPECT_GT(worstAngleError(0), 20);
}

}  // namespace
}  // namespace mocap
