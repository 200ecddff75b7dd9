// The legs of the plant and chase moves, and the damped Gauss-Newton solver that places a joint.
#include "tracker/filters/refine/legs.h"

#include <algorithm>
#include <string>

#include <Eigen/Cholesky>

namespace mocap {

std::vector<Leg> findLegs(const BodyModel& model) {
  std::vector<Leg> legs;
  for (const std::string& name : model.feet) {
    Leg leg;
    leg.segment = model.segmentIndex(name);
    for (int s = leg.segment; s >= 0; s = model.segments[s].parent)
      leg.chain.insert(leg.chain.begin(), s);
    const int knee = model.segments[leg.segment].parent;
    for (int s : {model.segments[knee].parent, knee, leg.segment})
      for (int d : model.segments[s].dofs) {
        const Dof& dof = model.dofs[d];
        const bool facing = std::find(model.facing_twists.begin(), model.facing_twists.end(),
                                      dof.name) != model.facing_twists.end();
        if (!dof.isFree() || dof.type != DofType::kRotation || facing) continue;
        leg.rotations.push_back(d);
        if (s != leg.segment) leg.dofs.push_back(d);
      }
    if (!leg.dofs.empty()) legs.push_back(std::move(leg));
  }
  return legs;
}

void moveJointTo(const BodyModel& model, LegData& data, const Leg& leg, int segment,
                 const Eigen::Vector3d& target, Eigen::VectorXd& tried) {
  constexpr int kIterations = 6;
  constexpr double kTolerance = 1e-4, kProbe = 1e-5, kDamping = 1e-4;  // metres, radians
  KinematicsData& kin = data.kinematics;
  Eigen::VectorXd& probe = data.probe;
  const int n = static_cast<int>(leg.dofs.size());
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    forwardKinematics(model, kin, tried, leg.chain);
    const Eigen::Vector3d at = kin.world[segment].translation();
    const Eigen::Vector3d residual = target - at;
    if (residual.norm() < kTolerance) break;
    // On the stack: two joints have at most 12 DOFs, and this runs for every planted trial.
    Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxLegDofs> jacobian(3, n);
    for (int k = 0; k < n; ++k) {
      probe = tried;
      probe[leg.dofs[k]] += kProbe;
      forwardKinematics(model, kin, probe, leg.chain);
      jacobian.col(k) = (kin.world[segment].translation() - at) / kProbe;
    }
    using Square =
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxLegDofs, kMaxLegDofs>;
    const Square normal = jacobian.transpose() * jacobian + kDamping * Square::Identity(n, n);
    const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxLegDofs, 1> change =
        normal.ldlt().solve(jacobian.transpose() * residual);
    for (int k = 0; k < n; ++k) {
      const Dof& dof = model.dofs[leg.dofs[k]];
      tried[leg.dofs[k]] = std::clamp(tried[leg.dofs[k]] + change[k], dof.min, dof.max);
    }
  }
}

}  // namespace mocap
