// The refinement's facing prior (FilterOptions::refine_facing_prior): a cost on a pose whose pelvis
// faces away from its legs, taken off the log-likelihood of every pose the refinement scores.
#pragma once

#include <utility>
#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"

namespace mocap {

struct FacingPrior {
  // The model's facing twists: each DOF with its sign, +1 or -1 as its axis is along or against
  // the first's (mirrored legs twist about opposite axes; the model refuses any other).
  std::vector<std::pair<int, double>> twists;
  double first_speed = 0;  // the first twist's speed limit, the unit of the cost
  double weight = 0;

  // How far `pose`'s pelvis faces from its legs, as a cost (0 without the prior).
  double cost(const Eigen::VectorXd& pose) const;
};

// The prior of `weight` for the model's facing twists; empty (no cost) if the model names none.
FacingPrior makeFacingPrior(const BodyModel& model, double weight);

}  // namespace mocap
