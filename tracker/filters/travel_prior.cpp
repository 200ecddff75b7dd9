// The travel prior: the root's ground track over the last frames against where it faces.
#include "tracker/filters/travel_prior.h"

#include <algorithm>

#include "tracker/model/kinematics.h"

namespace mocap {

TravelPrior::TravelPrior(const BodyModel& model, double weight)
    : model_(model), weight_(model.forward.isZero() ? 0 : weight) {
  for (int d : model.segments[0].dofs)
    if (model.dofs[d].type == DofType::kTranslation)
      speed_limit_ = std::max(speed_limit_, model.dofs[d].max_speed);
  if (speed_limit_ <= 0) weight_ = 0;
}

void TravelPrior::clear() {
  positions_.clear();
  strength_ = 0;
}

void TravelPrior::record(const Eigen::VectorXd& q) {
  if (weight_ == 0) return;
  positions_.push_back(localTransform(model_, 0, q).translation().head<2>());
  if (static_cast<int>(positions_.size()) > kHistory) positions_.pop_front();
  strength_ = 0;
  if (static_cast<int>(positions_.size()) < kHistory) return;
  const Eigen::Vector2d moved = positions_.back() - positions_.front();
  const double speed = moved.norm() / (kHistory - 1) / speed_limit_;
  strength_ = std::clamp((speed - 0.15) / 0.15, 0.0, 1.0);
  if (strength_ > 0) direction_ = moved.normalized();
}

double TravelPrior::cost(const Eigen::VectorXd& q) const {
  if (strength_ == 0) return 0;
  const Eigen::Vector2d facing = (localTransform(model_, 0, q).linear() * model_.forward).head<2>();
  const double length = facing.norm();
  if (length < 1e-9) return 0;  // the root faces straight up or down: no heading
  return weight_ * strength_ * (1 - facing.dot(direction_) / length) / 2;
}

}  // namespace mocap
