// The tracker's output for one frame set, as the pipeline hands it to the publisher: immutable
// once published and shared (never copied) between subscribers.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

namespace mocap {

// When the pipeline's stages handled a frame set (CLOCK_MONOTONIC ns; proto StageTimes).
struct StageTimes {
  int64_t silhouettes_start_ns = 0;
  int64_t silhouettes_end_ns = 0;
  int64_t track_start_ns = 0;
  int64_t track_end_ns = 0;
};

struct Pose {
  uint64_t frame_sequence = 0;
  int64_t capture_monotonic_ns = 0;  // the frame set's timestamp
  int64_t capture_wall_ns = 0;       // the same instant in Unix time
  int64_t publish_monotonic_ns = 0;  // when the publisher took it
  uint32_t body_version = 0;         // of the body tracked (Pipeline::trackedBody)
  std::vector<Eigen::Vector3d> points;           // BodyModel::points order, world, metres
  std::vector<Eigen::Quaterniond> orientations;  // per segment, world
  Eigen::VectorXd dofs;
  double score = 0;   // best particle's log-likelihood
  double spread = 0;  // particle spread around the estimate
  std::optional<double> silhouette_fit;  // tracker/search/acquire.h silhouetteFit, when measured
  std::optional<double> reference_error_mm;  // vs the true pose, when the source knows it

  StageTimes stages;  // where its latency went
};

using SharedPose = std::shared_ptr<const Pose>;

}  // namespace mocap
