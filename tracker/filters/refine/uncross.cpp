// The uncrossing: the crossed feet's cost, and the move that exchanges the feet between the legs.
#include "tracker/filters/refine/uncross.h"

#include <algorithm>

#include "tracker/filters/refine/pose_search.h"

namespace mocap {

CrossedLegs findCrossedLegs(const BodyModel& model, double weight) {
  CrossedLegs crossed;
  if (weight <= 0) return crossed;
  crossed.legs = findSwappedLegs(model, false, "refine_uncross");
  crossed.weight = weight;
  for (int f = 0; f < 2; ++f) {
    crossed.feet[f] = model.segmentIndex(model.feet[f]);
    crossed.hips[f] = model.segments[model.segments[crossed.feet[f]].parent].parent;
  }
  return crossed;
}

double CrossedLegs::crossing(const KinematicsData& kinematics) const {
  const Eigen::Vector3d across =
      (kinematics.world[hips[1]].translation() - kinematics.world[hips[0]].translation())
          .normalized();
  return -(kinematics.world[feet[1]].translation() - kinematics.world[feet[0]].translation())
              .dot(across);
}

double CrossedLegs::cost(const KinematicsData& kinematics) const {
  if (weight <= 0) return 0;
  const double over = std::max(0.0, crossing(kinematics) - kFreeCrossing) / kUnit;
  return weight * over * over;
}

double CrossedLegs::cost(const BodyModel& model, KinematicsData& scratch,
                         const Eigen::VectorXd& q) const {
  if (weight <= 0) return 0;
  forwardKinematics(model, scratch, q);
  return cost(scratch);
}

void uncrossLegs(const BodyModel& model, const CrossedLegs& crossed, const std::vector<Leg>& legs,
                 LegData& data, PoseSearch& search, MoveScratch& scratch, Eigen::VectorXd& q,
                 double& best) {
  if (legs.size() != 2 || search.budget() <= 2) return;
  forwardKinematics(model, data.kinematics, q);
  if (crossed.crossing(data.kinematics) <= 0) return;
  const Eigen::Vector3d foot[2] = {data.kinematics.world[crossed.feet[0]].translation(),
                                   data.kinematics.world[crossed.feet[1]].translation()};
  // The legs' angles exchanged first, then each leg moved to the other's foot.
  swapLegs(model, crossed.legs, 0, search, scratch, q, best, [&](Eigen::VectorXd& local) {
    for (const Leg& leg : legs)
      moveJointTo(model, data, leg, leg.segment, foot[leg.segment == crossed.feet[0] ? 1 : 0],
                  local);
  });
}

}  // namespace mocap
