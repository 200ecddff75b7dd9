// The refinement's plant move (FilterOptions::refine_plant): a step of the pelvis's position that
// fails both ways is tried again with the legs' hips and knees re-solved so the feet stay where
// they are (squatting, kneeling or shifting weight over planted feet).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "tracker/filters/refine/legs.h"
#include "tracker/model/body_model.h"

namespace mocap {

// Re-solves the planted feet's hip and knee angles in `tried` (which differs from `q` in the
// pelvis) so each foot's joint stays where it is at q.
void plantFeet(const BodyModel& model, const std::vector<Leg>& legs, LegData& data,
               const Eigen::VectorXd& q, Eigen::VectorXd& tried);

}  // namespace mocap
