// Forward kinematics of the articulated body model.
#include "tracker/model/kinematics.h"

#include <algorithm>

namespace mocap {

Eigen::Isometry3d localTransform(const BodyModel& model, int s, const Eigen::VectorXd& q) {
  const Segment& seg = model.segments[s];
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = seg.offset;
  for (int d : seg.dofs) {
    const Dof& dof = model.dofs[d];
    if (dof.type == DofType::kRotation) {
      t.rotate(Eigen::AngleAxisd(q[d], dof.axis));
    } else {
      t.translate(dof.axis * q[d]);
    }
  }
  return t;
}

namespace {

// The one placement step both versions share, so they give the same bits.
void place(const BodyModel& model, KinematicsData& data, const Eigen::VectorXd& q, int s) {
  const int parent = model.segments[s].parent;
  const Eigen::Isometry3d local = localTransform(model, s, q);
  data.world[s] = parent < 0 ? local : data.world[parent] * local;
}

}  // namespace

void forwardKinematics(const BodyModel& model, KinematicsData& data, const Eigen::VectorXd& q) {
  for (std::size_t s = 0; s < model.segments.size(); ++s)
    place(model, data, q, static_cast<int>(s));
}

void forwardKinematics(const BodyModel& model, KinematicsData& data, const Eigen::VectorXd& q,
                       const std::vector<int>& segments) {
  for (int s : segments) place(model, data, q, s);
}

std::vector<Eigen::Vector3d> pointPositions(const BodyModel& model, const KinematicsData& data) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(model.points.size());
  for (const BodyPoint& p : model.points) out.push_back(data.world[p.segment] * p.local);
  return out;
}

void clampToLimits(const BodyModel& model, Eigen::VectorXd& q) {
  for (std::size_t i = 0; i < model.dofs.size(); ++i)
    q[i] = std::clamp(q[i], model.dofs[i].min, model.dofs[i].max);
}

}  // namespace mocap
