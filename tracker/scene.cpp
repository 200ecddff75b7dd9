// Ground-truth silhouette rendering.
#include "tracker/scene.h"

#include <algorithm>

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

}  // namespace mocap
