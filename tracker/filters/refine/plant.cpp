// The plant move: each foot's position at the pose before the pelvis step, held by its leg.
#include "tracker/filters/refine/plant.h"

namespace mocap {

void plantFeet(const BodyModel& model, const std::vector<Leg>& legs, LegData& data,
               const Eigen::VectorXd& q, Eigen::VectorXd& tried) {
  std::vector<Eigen::Vector3d>& targets = data.points;
  targets.clear();
  for (const Leg& leg : legs) {
    forwardKinematics(model, data.kinematics, q, leg.chain);
    targets.push_back(data.kinematics.world[leg.segment].translation());
  }
  for (std::size_t f = 0; f < legs.size(); ++f)
    moveJointTo(model, data, legs[f], legs[f].segment, targets[f], tried);
}

}  // namespace mocap
