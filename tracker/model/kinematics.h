// Forward kinematics over (model, data, q): world transforms of every segment and world positions
// of the model's points. The model is never written; KinematicsData is the per-thread scratch.
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "tracker/model/body_model.h"

namespace mocap {

struct KinematicsData {
  explicit KinematicsData(const BodyModel& model) : world(model.segments.size()) {}
  std::vector<Eigen::Isometry3d> world;  // segment frame -> world frame
};

// The transform of segment `s` in its parent's frame for DOF vector `q`: the rest offset, then each
// of the joint's DOFs in order.
Eigen::Isometry3d localTransform(const BodyModel& model, int s, const Eigen::VectorXd& q);

// world[s] = world[parent] * localTransform(s) for every segment.
void forwardKinematics(const BodyModel& model, KinematicsData& data, const Eigen::VectorXd& q);

// The same for `segments` only (in model order), keeping the others' transforms: the whole body
// when they are every segment whose DOFs or ancestors' DOFs changed since data was last placed.
void forwardKinematics(const BodyModel& model, KinematicsData& data, const Eigen::VectorXd& q,
                       const std::vector<int>& segments);

// World positions of all model points, after forwardKinematics.
std::vector<Eigen::Vector3d> pointPositions(const BodyModel& model, const KinematicsData& data);

// Clamps every DOF of `q` into its limits.
void clampToLimits(const BodyModel& model, Eigen::VectorXd& q);

}  // namespace mocap
