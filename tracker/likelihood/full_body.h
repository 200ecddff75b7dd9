// The full-body likelihood the baselines (Condensation, annealed) weigh particles with: every
// segment with a shape, in model (DBN) order, through the same masked chain the factored filter
// uses, so all filters score a pose identically.
#pragma once

#include <vector>

#include "tracker/likelihood/likelihood.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/model/kinematics.h"

namespace mocap {

class FullBodyEvaluator {
 public:
  // One scratch per worker thread (`workers` of them).
  FullBodyEvaluator(const BodyModel& model, const Rig& rig, int points_per_circle, int workers);
  // Pixel counts of the whole body at pose q; safe to call concurrently with distinct workers.
  PixelCounts evaluate(const Eigen::VectorXd& q, const std::vector<SilhouetteMask>& masks,
                       int worker);
  // Segments rasterized per evaluation.
  int drawnSegments() const { return static_cast<int>(drawn_.size()); }

 private:
  struct Scratch {
    Scratch(const BodyModel& model, const Rig& rig, int points_per_circle, int max_rows);
    KinematicsData kinematics;
    ShapeRasterizer rasterizer;
    std::vector<RowSpan> spans;  // per drawn segment, per camera, max_rows each
    std::vector<Footprint> footprints;
    std::vector<std::vector<Footprint>> explained;  // per camera
  };

  const BodyModel& model_;
  const Rig& rig_;
  int max_rows_ = 0;
  std::vector<int> drawn_;  // segments with a shape, in model order
  std::vector<Scratch> scratch_;
};

}  // namespace mocap
