// The travel prior: where the root went over the last frames, against where a pose faces.
#include "tracker/filters/travel_prior.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"

namespace mocap {
namespace {

// A root that moves on the ground and turns, facing +Y at yaw 0; its speed limit is 0.1 m a frame.
constexpr const char* kWalker = R"(
name: walker
forward: [0, 1, 0]
segments:
  - name: pelvis
    dofs:
      - {name: tx, type: translation, axis: [1, 0, 0], min: -10, max: 10, max_speed: 0.1}
      - {name: ty, type: translation, axis: [0, 1, 0], min: -10, max: 10, max_speed: 0.1}
      - {name: yaw, axis: [0, 0, 1], min: -360, max: 360, max_speed: 12}
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.15, 0.1, 0.3]}
)";

Eigen::VectorXd pose(double x, double y, double yaw_deg) {
  return Eigen::Vector3d(x, y, yaw_deg * M_PI / 180);
}

// Records `frames` poses walking along +Y at `step` metres a frame.
void walk(TravelPrior& prior, int frames, double step) {
  for (int f = 0; f < frames; ++f) prior.record(pose(0, f * step, 0));
}

TEST(TravelPrior, ChargesABodyTurnedAwayFromWhereItGoes) {
  const BodyModel model = parseBodyModel(kWalker, "walker.yaml");
  TravelPrior prior(model, 10);
  walk(prior, TravelPrior::kHistory, 0.05);  // 1.25 m/s at 25 Hz
  ASSERT_TRUE(prior.active());
  EXPECT_NEAR(prior.cost(pose(0, 0, 0)), 0, 1e-9);     // facing the way it goes
  EXPECT_NEAR(prior.cost(pose(0, 0, 180)), 10, 1e-9);  // turned round
  EXPECT_NEAR(prior.cost(pose(0, 0, 90)), 5, 1e-9);    // sideways
  EXPECT_NEAR(prior.cost(pose(3, -2, -90)), 5, 1e-9);  // where the pose stands does not matter
}

TEST(TravelPrior, SpeaksOnlyOnceTheHistoryIsFull) {
  const BodyModel model = parseBodyModel(kWalker, "walker.yaml");
  TravelPrior prior(model, 10);
  walk(prior, TravelPrior::kHistory - 1, 0.05);
  EXPECT_FALSE(prior.active());
  EXPECT_EQ(prior.cost(pose(0, 0, 180)), 0);
  prior.record(pose(0, TravelPrior::kHistory * 0.05, 0));
  EXPECT_GT(prior.cost(pose(0, 0, 180)), 9);
  prior.clear();  // a new track
  EXPECT_EQ(prior.cost(pose(0, 0, 180)), 0);
}

TEST(TravelPrior, GrowsWithSpeedFromASlowWalk) {
  const BodyModel model = parseBodyModel(kWalker, "walker.yaml");
  const auto turnedRoundCost = [&](double step) {
    TravelPrior prior(model, 10);
    walk(prior, TravelPrior::kHistory, step);
    return prior.cost(pose(0, 0, 180));
  };
  EXPECT_EQ(turnedRoundCost(0.01), 0);            // 0.25 m/s: standing, shuffling
  EXPECT_NEAR(turnedRoundCost(0.0225), 5, 1e-6);  // halfway between 15 % and 30 % of the limit
  EXPECT_NEAR(turnedRoundCost(0.04), 10, 1e-9);   // 1 m/s
}

TEST(TravelPrior, IsOffWithoutAForwardAxisOrWeight) {
  BodyModel model = parseBodyModel(kWalker, "walker.yaml");
  TravelPrior unweighted(model, 0);
  walk(unweighted, TravelPrior::kHistory, 0.05);
  EXPECT_EQ(unweighted.cost(pose(0, 0, 180)), 0);
  model.forward.setZero();
  TravelPrior unnamed(model, 10);
  walk(unnamed, TravelPrior::kHistory, 0.05);
  EXPECT_EQ(unnamed.cost(pose(0, 0, 180)), 0);
}

// A pelvis on two straight legs casts the same silhouettes turned round, so the silhouettes cannot
// tell which way it walks. Tracked from a start facing backwards, the prior turns it round within
// the walk (the layers' injected headings, then the refinement); without it the track walks
// backwards to the end.
TEST(TravelPrior, TurnsATrackWalkingBackwardsRound) {
  const BodyModel model = parseBodyModel(R"(
name: straight_legged_walker
forward: [0, 1, 0]
segments:
  - name: pelvis
    offset: [0, 0, 0.9]
    dofs:
      - {name: tx, type: translation, axis: [1, 0, 0], min: -10, max: 10, max_speed: 0.1}
      - {name: ty, type: translation, axis: [0, 1, 0], min: -10, max: 10, max_speed: 0.1}
      - {name: yaw, axis: [0, 0, 1], min: -360, max: 360, max_speed: 12}
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.2, 0.1, 0.12]}
  - name: r_leg
    parent: pelvis
    offset: [0.12, 0, -0.08]
    shape: {type: cone, axis: [0, 0, -1], length: 0.8, radius_start: 0.07, radius_end: 0.05}
  - name: l_leg
    parent: pelvis
    offset: [-0.12, 0, -0.08]
    shape: {type: cone, axis: [0, 0, -1], length: 0.8, radius_start: 0.07, radius_end: 0.05}
)",
                                         "straight_legged_walker.yaml");
  const Rig rig = testing_support::twoCameras(Eigen::Vector3d(0, 0, 0.6), 1.2);
  const auto finalYawDeg = [&](double travel_prior) {
    WorkerPool pool(1);
    FilterOptions options = humanFilterDefaults();
    options.evaluations_per_frame = 300;
    options.travel_prior = travel_prior;
    auto filter = makeFilter("factored", model, rig, options, pool);
    filter->reset(pose(0, -0.6, 180));
    FrameEstimate estimate;
    for (int f = 0; f < 30; ++f)  // 1 m/s along +Y
      estimate =
          filter->step(testing_support::silhouettes(model, rig, pose(0, -0.6 + 0.04 * f, 0)));
    return std::abs(std::remainder(estimate.q[2], 2 * M_PI)) * 180 / M_PI;
  };
  EXPECT_LT(finalYawDeg(20), 15);
  EXPECT_GT(finalYawDeg(0), 150);
}

}  // namespace
}  // namespace mocap
