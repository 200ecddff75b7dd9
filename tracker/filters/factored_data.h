// The factored filter's per-frame and per-worker data: the particles, the candidates a layer
// scores, the nodes that place a segment in a particle's chain, and each worker's scratch. The
// plan they follow is FactoredPlan (built once, const).
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "tracker/likelihood/likelihood.h"
#include "tracker/likelihood/raster.h"
#include "tracker/model/body_model.h"
#include "tracker/model/kinematics.h"

namespace mocap {

// A segment placed in one particle's chain: its world pose and footprints (one per camera).
struct FactoredNode {
  Eigen::Isometry3d pose;
  int first_footprint = 0;  // index into the frame's node footprints
};

struct FactoredParticle {
  Eigen::VectorXd q;
  double log_weight = 0;
  std::vector<int> node;  // per segment: index into the frame's nodes, -1 until observed
};

struct FactoredCandidate {
  Eigen::VectorXd q;
  double log_weight = 0;  // parent's weight times this layer's segment factor
  double selection = 0;   // what the layer ranks by: log_weight, or the whole-body look-ahead
  int parent = 0;
  Eigen::Isometry3d pose;
};

// For Lookahead::kBody, per parent particle and layer: the segments it has not placed yet (outside
// the layer's subtree) at their previous pose, after the placed ones.
struct RestOfBody {
  RestOfBody(std::size_t cameras, std::size_t segments, int max_rows)
      : explained(cameras), spans(segments * cameras * max_rows), camera_counts(cameras) {}
  std::vector<std::vector<Footprint>> explained;  // per camera: placed, then rest
  std::vector<RowSpan> spans;                     // the rest's footprints
  std::vector<PixelCounts> camera_counts;         // of the rest, per camera
  long renders = 0;
};

// One worker's scratch while it scores candidates.
struct WorkerScratch {
  WorkerScratch(const BodyModel& model, int points_per_circle, std::size_t cameras,
                std::size_t segments, int max_rows)
      : kinematics(model),
        rasterizer(points_per_circle),
        explained(cameras),
        footprints(cameras),
        poses(segments),
        lookahead_spans(segments * cameras * max_rows) {}
  KinematicsData kinematics;
  ShapeRasterizer rasterizer;
  std::vector<std::vector<Footprint>> explained;  // per camera
  std::vector<Footprint> footprints;              // per camera, of the descendant being looked at
  std::vector<Eigen::Isometry3d> poses;           // per segment, for the look-ahead
  std::vector<RowSpan> lookahead_spans;           // per descendant, per camera, max_rows each
  std::vector<int> placed;                        // first footprint of each explained node
};

}  // namespace mocap
