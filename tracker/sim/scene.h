// The scene simulator: renders ground-truth silhouettes of a body model in a pose into calibrated
// virtual cameras. The ground-truth source of experiments and tests, and the fake camera's
// renderer.
#pragma once

#include <vector>

#include <opencv2/core/mat.hpp>

#include "tracker/likelihood/raster.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/motion.h"

namespace mocap {

// Finely tessellated by default so the tracker's coarser outlines never match the truth exactly.
constexpr int kSimulatorPointsPerCircle = 48;

class SceneRenderer {
 public:
  SceneRenderer(const BodyModel& model, const Rig& rig,
                int points_per_circle = kSimulatorPointsPerCircle);
  // One CV_8UC1 image per camera, 255 where the body is.
  std::vector<cv::Mat> renderSilhouettes(const Eigen::VectorXd& q);
  // Renders into existing images (resized if needed) to avoid reallocation per frame.
  void renderSilhouettes(const Eigen::VectorXd& q, std::vector<cv::Mat>& images);
  // Leaves segment `segment` out of camera `camera`'s silhouette until cleared (a missed limb).
  void hideSegment(int camera, int segment) { hidden_.emplace_back(camera, segment); }
  void clearHidden() { hidden_.clear(); }

 private:
  const BodyModel& model_;
  const Rig& rig_;
  KinematicsData kinematics_;
  ShapeRasterizer rasterizer_;
  std::vector<RowSpan> spans_;
  std::vector<std::pair<int, int>> hidden_;  // (camera, segment)
};

// `cameras` cameras on a circle around the volume the motion covers, 1.6 m high, looking at the
// middle of the body's path, the first two 90 degrees apart as a lab would place a pair; the focal
// length keeps the whole path in view.
Rig labRig(int cameras, const BodyModel& model, const Motion& motion, int width = 780,
           int height = 580);

// Sets every pixel of `footprint` in `image` (CV_8UC1) to `value`.
void fillFootprint(cv::Mat& image, const Footprint& footprint, uint8_t value);

}  // namespace mocap
