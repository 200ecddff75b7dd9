// The hold move: which children a rotation holds, and their angles re-solved after it.
#include "tracker/filters/refine/hold.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "tracker/model/kinematics.h"

namespace mocap {

std::vector<std::vector<HeldChild>> findHeldChildren(const BodyModel& model,
                                                     const std::vector<int>& dofs) {
  std::vector<std::vector<HeldChild>> out(dofs.size());
  for (std::size_t i = 0; i < dofs.size(); ++i) {
    const Dof& dof = model.dofs[dofs[i]];
    if (dof.type != DofType::kRotation) continue;
    for (std::size_t c = 0; c < model.segments.size(); ++c) {
      const Segment& child = model.segments[c];
      if (child.parent != dof.segment || child.dofs.size() != 3) continue;
      HeldChild held{static_cast<int>(c), {}, {}};
      bool ball = true;
      for (int j = 0; j < 3 && ball; ++j) {
        const Dof& angle = model.dofs[child.dofs[j]];
        Eigen::Index axis = 0;
        const double largest = angle.axis.cwiseAbs().maxCoeff(&axis);
        ball = angle.type == DofType::kRotation && angle.isFree() && largest == 1.0 &&
               angle.axis.cwiseAbs().sum() == 1.0;
        held.axis[j] = static_cast<int>(axis);
        held.sign[j] = angle.axis[axis];
      }
      ball = ball && held.axis[0] != held.axis[1] && held.axis[1] != held.axis[2] &&
             held.axis[0] != held.axis[2];
      if (ball) out[i].push_back(held);
    }
  }
  return out;
}

void holdChildren(const BodyModel& model, const std::vector<HeldChild>& children,
                  const Eigen::VectorXd& q, Eigen::VectorXd& tried) {
  const int s = model.segments[children[0].segment].parent;
  const Eigen::Matrix3d turn =
      localTransform(model, s, tried).linear().transpose() * localTransform(model, s, q).linear();
  for (const HeldChild& held : children) {
    const Segment& child = model.segments[held.segment];
    const Eigen::Matrix3d target = turn * localTransform(model, held.segment, q).linear();
    // target = R(e_a0, phi0) R(e_a1, phi1) R(e_a2, phi2): two solutions, the one nearer the
    // current angles is taken.
    const Eigen::Vector3d phi = target.eulerAngles(held.axis[0], held.axis[1], held.axis[2]);
    const Eigen::Vector3d other(phi[0] + M_PI, M_PI - phi[1], phi[2] + M_PI);
    double best_distance = INFINITY;
    Eigen::Vector3d best;
    for (const Eigen::Vector3d& solution : {phi, other}) {
      Eigen::Vector3d angles;
      double distance = 0;
      for (int j = 0; j < 3; ++j) {
        const double current = q[child.dofs[j]];
        const double a = held.sign[j] * solution[j];
        angles[j] = a + 2 * M_PI * std::round((current - a) / (2 * M_PI));
        distance += std::abs(angles[j] - current);
      }
      if (distance < best_distance) {
        best_distance = distance;
        best = angles;
      }
    }
    for (int j = 0; j < 3; ++j) {
      const Dof& angle = model.dofs[child.dofs[j]];
      tried[child.dofs[j]] = std::clamp(best[j], angle.min, angle.max);
    }
  }
}

}  // namespace mocap
