// Ground-truth silhouette rendering.
#include "tracker/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace mocap {

SceneRenderer::SceneRenderer(const BodyModel& model, const Rig& rig, int points_per_circle)
    : model_(model), rig_(rig), kinematics_(model), rasterizer_(points_per_circle) {
  int rows = 0;
  for (const CameraModel& c : rig) rows = std::max(rows, c.height);
  spans_.resize(rows);
}

std::vector<cv::Mat> SceneRenderer::renderSilhouettes(const Eigen::VectorXd& q) {
  std::vector<cv::Mat> images;
  renderSilhouettes(q, images);
  return images;
}

void SceneRenderer::renderSilhouettes(const Eigen::VectorXd& q, std::vector<cv::Mat>& images) {
  forwardKinematics(model_, kinematics_, q);
  images.resize(rig_.size());
  for (std::size_t c = 0; c < rig_.size(); ++c) {
    images[c].create(rig_[c].height, rig_[c].width, CV_8UC1);
    images[c].setTo(0);
    for (std::size_t s = 0; s < model_.segments.size(); ++s) {
      if (std::find(hidden_.begin(), hidden_.end(),
                    std::pair<int, int>(static_cast<int>(c), static_cast<int>(s))) != hidden_.end())
        continue;
      const Footprint f = rasterizer_.rasterize(model_.segments[s].shape, kinematics_.world[s],
                                                rig_[c], spans_.data());
      fillFootprint(images[c], f, 255);
    }
  }
}

void fillFootprint(cv::Mat& image, const Footprint& footprint, uint8_t value) {
  for (int y = footprint.y0; y < footprint.y1; ++y) {
    const RowSpan& span = footprint.spans[y - footprint.y0];
    uint8_t* row = image.ptr<uint8_t>(y);
    std::fill(row + span.x0, row + span.x1, value);
  }
}

Rig labRig(int cameras, const BodyModel& model, const Motion& motion, int width, int height) {
  // The horizontal extent of the pelvis path.
  KinematicsData kin(model);
  const int pelvis = std::max(0, model.pointIndex("pelvis"));
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (const Eigen::VectorXd& q : motion) {
    forwardKinematics(model, kin, q);
    const Eigen::Vector3d p = kin.world[model.points[pelvis].segment] * model.points[pelvis].local;
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  const double reach = 0.5 * (hi - lo).norm() + 0.7;  // path half-length plus arms and margin
  const double distance = std::max(4.0, reach + 3.0);
  const double focal = std::min(0.5 * width * distance / reach, 0.5 * height * distance / 1.2);
  const Eigen::Vector3d target(centre.x(), centre.y(), 0.9);
  Rig rig;
  for (int i = 0; i < cameras; ++i) {
    const double azimuth = (45.0 + (cameras <= 4 ? 90.0 * i : 360.0 * i / cameras)) * M_PI / 180.0;
    const Eigen::Vector3d eye(centre.x() + distance * std::cos(azimuth),
                              centre.y() + distance * std::sin(azimuth), 1.6);
    rig.push_back(CameraModel::lookAt("cam" + std::to_string(i), eye, target,
                                      Eigen::Vector3d::UnitZ(), width, height, focal));
  }
  return rig;
}

}  // namespace mocap
