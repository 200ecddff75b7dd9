// The refinement's hold move (FilterOptions::refine_hold): a rotation step of a segment that fails
// both ways is tried again with its ball-joint children re-solved so they keep their world
// orientation (a pelvis turned back without swinging the legs and the trunk).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"

namespace mocap {

// A child segment whose joint is three rotations about distinct coordinate axes (sign * e_axis).
struct HeldChild {
  int segment = -1;
  int axis[3];
  double sign[3];
};

// Per DOF of `dofs`: if it is a rotation, the children of its segment whose joint is three
// rotations about distinct coordinate axes (so any orientation has its angles); otherwise none.
std::vector<std::vector<HeldChild>> findHeldChildren(const BodyModel& model,
                                                     const std::vector<int>& dofs);

// Sets the held children's angles in `tried` (which differs from `q` in their parent's DOFs) so
// each child keeps the world orientation it has at q, within its joint limits.
void holdChildren(const BodyModel& model, const std::vector<HeldChild>& children,
                  const Eigen::VectorXd& q, Eigen::VectorXd& tried);

}  // namespace mocap
