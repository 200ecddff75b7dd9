// Coordinate search of a pose: it climbs to the best pose within the finest steps, stops at the
// DOFs' limits, and never spends more scores than its budget.
#include "tracker/search/pose_search.h"

#include <gtest/gtest.h>

#include "tracker/model/builtin_models.h"

namespace mocap {
namespace {

TEST(CoordinateSearch, ClimbsToTheBestPoseWithinTheFinestStepsAndTheLimits) {
  const BodyModel human = builtinHumanModel();
  const int knee = human.dofIndex("l_knee_flex"), x = human.dofIndex("root_tx");
  const double knee_max = human.dofs[knee].max;
  // Best with the knee beyond its limit and the root at 0.3 m.
  const auto score = [&](const Eigen::VectorXd& q) {
    return -std::pow(q[knee] - (knee_max + 1), 2) - std::pow(q[x] - 0.3, 2);
  };
  SearchDofs search;
  search.add(knee, 0.2, 0.001);
  search.add(x, 0.05, 0.001);
  Eigen::VectorXd q = human.neutralPose();
  double value = score(q);
  const int spent = coordinateSearch(human, score, search, 1000, q, value);
  EXPECT_LT(spent, 1000);  // it stopped because every step got finer than its finest
  EXPECT_DOUBLE_EQ(q[knee], knee_max);
  EXPECT_NEAR(q[x], 0.3, 0.002);
  EXPECT_DOUBLE_EQ(value, score(q));
  // Everything else untouched.
  Eigen::VectorXd others = q - human.neutralPose();
  others[knee] = others[x] = 0;
  EXPECT_EQ(others.norm(), 0);

  // A budget is a hard cap on the scores spent.
  int calls = 0;
  const auto counted = [&](const Eigen::VectorXd& pose) {
    ++calls;
    return score(pose);
  };
  Eigen::VectorXd from = human.neutralPose();
  double from_value = score(from);
  EXPECT_EQ(coordinateSearch(human, counted, search, 7, from, from_value), 7);
  EXPECT_EQ(calls, 7);
  EXPECT_GT(from_value, score(human.neutralPose()));
}

}  // namespace
}  // namespace mocap
