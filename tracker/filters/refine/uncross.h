// The refinement's uncrossing (FilterOptions::refine_uncross): a cost on feet crossed over in the
// body's own frame, and the move that gives each leg the other's foot. Acquisition and its trials
// charge the same cost (AcquireOptions::uncross), so a track and its rivals are compared on what
// the refinement optimizes.
//
// Two views of a stride fit nearly as well with the legs' labels exchanged: the feet stay where
// the silhouettes put them, each reached by the other leg, so the legs cross. The cost makes such
// a pose worse than its uncrossed twin, and the move proposes the twin, which no step of one leg
// reaches.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "tracker/filters/refine/legs.h"
#include "tracker/filters/refine/swap.h"
#include "tracker/model/body_model.h"
#include "tracker/model/kinematics.h"

namespace mocap {

class PoseSearch;
struct MoveScratch;

struct CrossedLegs {
  // Feet may cross this far before they cost anything (people cross a little turning, and the
  // walk's kneel crosses by 0.21 m), and the cost's unit beyond it. Metres.
  static constexpr double kFreeCrossing = 0.15;
  static constexpr double kUnit = 0.1;

  double weight = 0;  // 0: no cost, no move
  // The model's two feet and the segments whose origins are their hip joints (their
  // grandparents), in the order of BodyModel::feet.
  int feet[2] = {-1, -1};
  int hips[2] = {-1, -1};
  // The two legs' DOFs, paired (findSwappedLegs), which the move exchanges.
  LegSwap legs;

  // How far the feet have passed each other across the body, in metres, at the pose `kinematics`
  // is placed at: their separation along the line from one hip to the other, counted against
  // that line. Negative while each foot is on its own hip's side (a person standing: minus the
  // stance's width).
  double crossing(const KinematicsData& kinematics) const;
  // W (max(0, crossing - kFreeCrossing) / kUnit)^2; 0 without a weight.
  double cost(const KinematicsData& kinematics) const;
  // The same at pose q, placed in `scratch` (left alone without a weight).
  double cost(const BodyModel& model, KinematicsData& scratch, const Eigen::VectorXd& q) const;
};

// The cost of `weight` for the model's feet; no cost for weight 0. Throws std::invalid_argument
// naming refine_uncross unless the model has two feet with the same free DOFs per segment.
CrossedLegs findCrossedLegs(const BodyModel& model, double weight);

// If q's feet cross at all, the legs exchange their angles (so each starts near the mirror image
// of the other's foot: a solver started from the crossed leg folds its knee) and each of `legs`
// (findLegs) is then moved by its hip and knee to the other's foot; that pose is searched locally
// on the legs' angles
// (up to 2 poses per angle) and kept in q and `best` if it beats the pose, otherwise the
// evaluator goes back to q.
void uncrossLegs(const BodyModel& model, const CrossedLegs& crossed, const std::vector<Leg>& legs,
                 LegData& data, PoseSearch& search, MoveScratch& scratch, Eigen::VectorXd& q,
                 double& best);

}  // namespace mocap
