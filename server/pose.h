// The tracker's output for one frame set, as the pipeline hands it to the publisher: immutable
// once published and shared (never copied) between subscribers.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

namespace mocap {

class BodyModel;

// When the pipeline's stages handled a frame set (CLOCK_MONOTONIC ns; proto StageTimes).
struct StageTimes {
  int64_t silhouettes_start_ns = 0;
  int64_t silhouettes_end_ns = 0;
  int64_t track_start_ns = 0;
  int64_t track_end_ns = 0;
};

// The stages a pose's latency splits into, in pipeline order, as proto Status.stage_latency names
// them; stageDurations gives each one's time.
inline constexpr std::array<const char*, 5> kLatencyStages = {
    "capture_to_silhouettes", "silhouettes", "silhouettes_to_tracker", "track",
    "tracker_to_publisher"};

struct Pose {
  uint64_t frame_sequence = 0;
  int64_t capture_monotonic_ns = 0;  // the frame set's timestamp
  int64_t capture_wall_ns = 0;       // the same instant in Unix time
  int64_t publish_monotonic_ns = 0;  // when the publisher took it
  uint32_t body_version = 0;         // of the body tracked (Pipeline::trackedBody)
  // That body, whose points these are (null where a pose is made outside the pipeline). Carried
  // with the pose so that a reader needs no lock to know it: Pipeline::trackedBody takes the fit
  // job's, which the tracker takes to switch bodies.
  std::shared_ptr<const BodyModel> body;
  std::vector<Eigen::Vector3d> points;           // BodyModel::points order, world, metres
  std::vector<Eigen::Quaterniond> orientations;  // per segment, world
  Eigen::VectorXd dofs;
  double score = 0;                      // best particle's log-likelihood
  double spread = 0;                     // particle spread around the estimate
  std::optional<double> silhouette_fit;  // tracker/search/acquire.h silhouetteFit, when measured
  std::optional<double> reference_error_mm;  // vs the true pose, when the source knows it

  StageTimes stages;  // where its latency went
};

using SharedPose = std::shared_ptr<const Pose>;

// The nanoseconds `pose` spent in each of kLatencyStages, the publisher having taken it at
// `publish_ns`.
inline std::array<int64_t, kLatencyStages.size()> stageDurations(const Pose& pose,
                                                                 int64_t publish_ns) {
  const StageTimes& s = pose.stages;
  const int64_t times[] = {pose.capture_monotonic_ns, s.silhouettes_start_ns, s.silhouettes_end_ns,
                           s.track_start_ns,          s.track_end_ns,         publish_ns};
  std::array<int64_t, kLatencyStages.size()> durations{};
  for (std::size_t k = 0; k < durations.size(); ++k) durations[k] = times[k + 1] - times[k];
  return durations;
}

}  // namespace mocap
