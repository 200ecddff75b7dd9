// Scoring of the human experiment beside the mean error: limbs on their own, legs exchanged, and
// how long a run is lost and how soon it first locks on.
#pragma once

#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "tracker/likelihood/full_body.h"
#include "tracker/likelihood/likelihood.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/model/kinematics.h"

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

// A run of the human experiment scored frame by frame: the mean per-joint error, per joint and per
// limb, the lost frames and their causes, the tracked body's floor, and optionally a per-frame
// trace (CSV) that tells a search failure (the estimate scores below the truth) from an ambiguity
// of the silhouettes (it scores as well or better while far off).
class HumanRunScore {
 public:
  // `model` is the subject's body, whose points the truth gives; `tracked_body` the body the
  // tracker estimates. With `score_floor` (the tracked body is not the subject's own) each frame
  // also scores the tracked body's pose nearest the truth, which no tracker can beat on that body.
  // Throws std::runtime_error when `trace_path` (empty: no trace) cannot be written.
  HumanRunScore(const BodyModel& model, const BodyModel& tracked_body, const Rig& rig,
                const LikelihoodParams& likelihood, bool score_floor,
                const std::string& trace_path);

  // Scores one tracked frame: its index, the true pose and its joints, the estimate.
  void add(int frame, const Eigen::VectorXd& truth, const std::vector<Eigen::Vector3d>& true_points,
           const Eigen::VectorXd& estimate, bool found, const std::vector<SilhouetteMask>& masks);

  // Averages over the frames added: mpjpe_mm, per_joint_mm, per_limb_mm, limb_lost_frames,
  // max_frame_mpjpe_mm, lost_frames and lost_frame_causes; with a trace, lost_frames_truth_ahead.
  void summarize(nlohmann::json& out) const;

  int scoredFrames() const { return static_cast<int>(frames_.size()); }
  double meanBodyFloorMm() const { return body_floor_mm_ / scoredFrames(); }
  // The tracked body's pose nearest the last frame's true joints (with `score_floor`).
  const Eigen::VectorXd& floorPose() const { return floor_pose_; }
  int longestLossFrames() const { return longestLoss(frame_error_); }
  // The first frame (its index in the motion) under 50 mm, of the whole body or of the left arm;
  // empty if none is.
  std::optional<int> recoveryFrame() const;
  std::optional<int> leftArmRecoveryFrame() const;
  std::optional<int> firstLockFrame() const;

 private:
  // The first frame whose error in `errors` (one per frame added) is under 50 mm.
  std::optional<int> firstUnder50(const std::vector<double>& errors) const;
  int limbNamed(const char* name) const;
  double latestLimbError(int limb) const;
  double headingErrorDeg(const std::vector<Eigen::Vector3d>& truth,
                         const std::vector<Eigen::Vector3d>& estimate) const;
  void scoreFloor(const std::vector<Eigen::Vector3d>& true_points);
  void writeTrace(int frame, const Eigen::VectorXd& truth, const Eigen::VectorXd& estimate,
                  bool found, const std::vector<SilhouetteMask>& masks, double heading_error,
                  double legs_swapped, bool lost);

  const BodyModel& model_;
  const BodyModel& tracked_body_;
  const LikelihoodParams& likelihood_;
  const bool score_floor_;
  KinematicsData tracked_kin_;
  const std::vector<Limb> limbs_;
  const int left_leg_, right_leg_, left_arm_, right_arm_;  // into limbs_, -1 if missing
  const int l_hip_, r_hip_;

  std::vector<int> frames_;  // the frames added, by their index in the motion
  std::vector<double> frame_error_;
  std::vector<double> per_joint_;                // summed over the frames
  std::vector<std::vector<double>> limb_error_;  // per limb, per frame
  std::map<std::string, int> lost_causes_ = {
      {"legs_swapped", 0}, {"heading", 0}, {"legs", 0}, {"arms", 0}, {"other", 0}};
  Eigen::VectorXd floor_pose_;  // warm start of the next frame's floor
  double body_floor_mm_ = 0;    // summed over the frames

  std::ofstream trace_;
  std::unique_ptr<FullBodyEvaluator> truth_scorer_, estimate_scorer_;  // with a trace only
  int lost_truth_ahead_ = 0;  // lost frames whose truth scores over 20 units above the estimate
};

}  // namespace mocap
