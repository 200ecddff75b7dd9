// The refinement's facing prior: W (c / s)^2, c the mean of the signed facing twists and s the
// first's speed limit (see FilterOptions::refine_facing_prior).
#include "tracker/filters/refine/facing_prior.h"

#include <string>

namespace mocap {

FacingPrior makeFacingPrior(const BodyModel& model, double weight) {
  FacingPrior prior;
  prior.weight = weight;
  if (model.facing_twists.empty()) return prior;
  const Eigen::Vector3d& first = model.dofs[model.dofIndex(model.facing_twists[0])].axis;
  for (const std::string& name : model.facing_twists) {
    const int d = model.dofIndex(name);
    prior.twists.push_back({d, model.dofs[d].axis.dot(first) > 0 ? 1.0 : -1.0});
  }
  prior.first_speed = model.dofs[prior.twists[0].first].max_speed;
  return prior;
}

double FacingPrior::cost(const Eigen::VectorXd& pose) const {
  if (twists.empty()) return 0;
  double sum = 0;
  for (const auto& [d, sign] : twists) sum += sign * pose[d];
  const double c = sum / static_cast<double>(twists.size()) / first_speed;
  return weight * c * c;
}

}  // namespace mocap
