// The legs the refinement's plant and chase moves work on (each of the model's `feet` with the
// two segments above it), and the solver that moves a joint of a leg to a point by its hip and
// knee angles.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"
#include "tracker/model/kinematics.h"

namespace mocap {

constexpr int kMaxLegDofs = 12;  // two joints of at most 6 DOFs each

// A leg of the model's `feet`: the foot segment, the DOFs that place it (its hip and knee), the
// segments from the root down to it (all that places it) and every free rotation of its
// grandparent, parent and itself; the model's facing twists left out of both.
struct Leg {
  int segment = -1;
  std::vector<int> dofs;
  std::vector<int> chain;
  std::vector<int> rotations;
};

// Each of the model's feet with the free rotations of the two segments above it, facing twists
// left out (the facing prior governs them, and without them hip and knee have three angles for
// the foot's three coordinates). A foot with no such DOF has no leg.
std::vector<Leg> findLegs(const BodyModel& model);

// Scratch of the leg solver and of its callers.
struct LegData {
  explicit LegData(const BodyModel& model) : kinematics(model) {}
  KinematicsData kinematics;
  Eigen::VectorXd probe;
  std::vector<Eigen::Vector3d> points;  // the callers' joint positions
};

// Moves the origin of `segment` (the leg's foot or a segment above it on its chain) towards
// `target` by the leg's hip and knee angles in `tried`: damped Gauss-Newton steps on a numeric
// Jacobian, clamped to the joint limits.
void moveJointTo(const BodyModel& model, LegData& data, const Leg& leg, int segment,
                 const Eigen::Vector3d& target, Eigen::VectorXd& tried);

}  // namespace mocap
