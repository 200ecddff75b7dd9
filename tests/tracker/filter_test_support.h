// Shared set-up of the filter tests: the hand, its 3-camera rig at a reduced resolution (the
// filters do not care, and the suite stays fast), and silhouettes of a pose.
#pragma once

#include <vector>

#include "tracker/experiments/hand_experiment.h"
#include "tracker/kinematics.h"
#include "tracker/scene.h"

namespace mocap::testing_support {

struct HandScene {
  BodyModel model = builtinHandModel();
  Rig rig = handRig(3, 390, 290);

  std::vector<SilhouetteMask> masks(const Eigen::VectorXd& q) {
    SceneRenderer renderer(model, rig);
    std::vector<SilhouetteMask> out;
    for (const cv::Mat& image : renderer.renderSilhouettes(q)) out.emplace_back(image);
    return out;
  }

  // Mean distance (metres) between the model points at two poses.
  double pointError(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
    KinematicsData ka(model), kb(model);
    forwardKinematics(model, ka, a);
    forwardKinematics(model, kb, b);
    const auto pa = pointPositions(model, ka), pb = pointPositions(model, kb);
    double sum = 0;
    for (std::size_t i = 0; i < pa.size(); ++i) sum += (pa[i] - pb[i]).norm();
    return sum / pa.size();
  }

  // A pose a few speed limits away from `q` in every DOF (within the limits).
  Eigen::VectorXd perturbed(const Eigen::VectorXd& q, double speeds) const {
    Eigen::VectorXd out = q;
    for (std::size_t d = 0; d < model.dofs.size(); ++d)
      out[d] += (d % 2 ? 1 : -1) * speeds * model.dofs[d].max_speed;
    clampToLimits(model, out);
    return out;
  }
};

}  // namespace mocap::testing_support
