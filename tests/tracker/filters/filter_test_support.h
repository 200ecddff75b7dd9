// Shared set-up of the filter tests: the hand, its 3-camera rig at a reduced resolution (the
// filters do not care, and the suite stays fast), and silhouettes of a pose.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tracker/filters/filter.h"
#include "tracker/model/builtin_models.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/motion.h"
#include "tracker/sim/scene.h"

namespace mocap::testing_support {

// The silhouettes of `model` at pose `q` in every camera of `rig`, as the filters take them.
inline std::vector<SilhouetteMask> silhouettes(const BodyModel& model, const Rig& rig,
                                               const Eigen::VectorXd& q) {
  SceneRenderer renderer(model, rig);
  std::vector<SilhouetteMask> out;
  for (const cv::Mat& image : renderer.renderSilhouettes(q)) out.emplace_back(image);
  return out;
}

struct HandScene {
  BodyModel model = builtinHandModel();
  Rig rig = handRig(3, 390, 290);

  std::vector<SilhouetteMask> masks(const Eigen::VectorXd& q) { return silhouettes(model, rig, q); }

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

// Tracks a short generated motion with each thread count and expects the very same estimates:
// candidates are generated in one thread and ranked with deterministic ties, so the pool's
// scheduling must not show.
inline void expectSameEstimatesForThreadCounts(const std::string& method,
                                               const FilterOptions& options,
                                               const std::vector<int>& thread_counts, int frames) {
  HandScene scene;
  const Motion motion = generateMotion(scene.model, frames, 4);
  std::vector<std::vector<SilhouetteMask>> masks;
  for (const auto& q : motion) masks.push_back(scene.masks(q));
  std::vector<Eigen::VectorXd> first;
  for (int threads : thread_counts) {
    WorkerPool pool(threads);
    auto filter = makeFilter(method, scene.model, scene.rig, options, pool);
    filter->reset(motion[0]);
    for (std::size_t f = 0; f < motion.size(); ++f) {
      const Eigen::VectorXd q = filter->step(masks[f]).q;
      if (first.size() < motion.size()) {
        first.push_back(q);
      } else {
        EXPECT_EQ(q, first[f]) << method << ", " << threads << " threads, frame " << f;
      }
    }
  }
}

// Two 240x180 cameras 90 degrees apart, 3 m from the vertical axis at `height`, looking at
// `target`.
inline Rig twoCameras(const Eigen::Vector3d& target, double height) {
  Rig rig;
  for (int i = 0; i < 2; ++i) {
    const double azimuth = (30.0 + 90.0 * i) * M_PI / 180;
    rig.push_back(
        CameraModel::lookAt("cam" + std::to_string(i),
                            Eigen::Vector3d(3 * std::cos(azimuth), 3 * std::sin(azimuth), height),
                            target, Eigen::Vector3d::UnitZ(), 240, 180, 200));
  }
  return rig;
}

}  // namespace mocap::testing_support
