// Scoring of the human experiment beside the mean error: limbs on their own, legs exchanged, and
// how long a run is lost and how soon it first locks on.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"

namespace mocap {

// A frame is lost when its mean per-joint error is over this (millimetres).
inline constexpr double kLostMm = 100.0;
// Frames a run must stay under kLostMm for its first of them to count as the first lock.
inline constexpr int kLockFrames = 5;

// The four limbs by their model points: a limb lost while the rest is tracked moves the mean over
// 19 joints by a few centimetres only, so limbs are also scored on their own.
struct Limb {
  const char* name;
  std::vector<int> points;
};
std::vector<Limb> limbsOf(const BodyModel& model);

// The legs' error with the estimate's left leg scored against the truth's right leg and the other
// way round: well under the legs' own error when the tracker swapped them, a silhouette ambiguity.
// NaN for legs that do not pair up point for point, which no comparison takes for a swap.
double legsSwappedError(const Limb& left, const Limb& right,
                        const std::vector<Eigen::Vector3d>& truth,
                        const std::vector<Eigen::Vector3d>& estimate);

// The longest run of consecutive entries of `frame_error` (mm) over kLostMm.
int longestLoss(const std::vector<double>& frame_error);
// The index of the first entry of `frame_error` that starts a lock: it and the kLockFrames - 1
// after it (fewer where the run ends) all under kLostMm. Empty if none does.
std::optional<int> firstLock(const std::vector<double>& frame_error);

}  // namespace mocap
