// The full-body likelihood (full_body.h) kept up to date across poses that differ in a few DOFs,
// for the factored filter's refinement: a trial re-places and re-rasterizes only the segments those
// DOFs move (their subtrees) and counts only them, with exactly the counts FullBodyEvaluator::evaluate
// gives for the same pose.
//
// The full-body counts do not depend on the segments' order: matched = silhouette pixels covered by
// the union of all footprints, outside and area = sums over the footprints. So with the moved
// segments M and the rest R, matched = matched(R) + what M adds over R, the masked chain of M's
// footprints with R's as explained. matched(R) follows from the current pose's counts minus the
// current M's chain over R; it holds while R stands still, which it does for every trial of the same
// DOFs (the refinement tries each DOF both ways, accepted or not), so it is counted once per set.
#pragma once

#include <vector>

#include "tracker/body_model.h"
#include "tracker/camera.h"
#include "tracker/kinematics.h"
#include "tracker/likelihood.h"

namespace mocap {

class IncrementalBodyEvaluator {
 public:
  IncrementalBodyEvaluator(const BodyModel& model, const Rig& rig, int points_per_circle);

  // Evaluates the whole body at q against `masks` (kept by reference until the next reset) and
  // makes it the current pose. Drops any pending trial.
  PixelCounts reset(const Eigen::VectorXd& q, const std::vector<SilhouetteMask>& masks);
  // The counts at q, which may differ from the current pose in any DOFs; then accept() makes q the
  // current pose or reject() restores the current one, before the next trial.
  PixelCounts trial(const Eigen::VectorXd& q);
  void accept();
  void reject();

  const PixelCounts& counts() const { return counts_; }
  const Eigen::VectorXd& pose() const { return q_; }
  // Segments rasterized (in all cameras) so far, by resets and trials.
  long renders() const { return renders_; }

 private:
  struct SegmentCounts {
    long area = 0;
    long silhouette = 0;  // silhouette pixels inside the footprints, other segments ignored
  };

  // Rasterizes drawn segment k at its placed pose into slot `slot`.
  void draw(int k, int slot);
  // Matched pixels the moved drawn segments add over the rest, with their footprints of the current
  // pose (`trial` false) or of the trial; each one's own counts go to trial_counts_.
  long movedOverRest(bool trial);
  // Makes the rest's explained footprints and matched pixels those of the trial's moved set.
  void restFor();
  Footprint& footprint(int k, std::size_t c, int slot) {
    return footprints_[(static_cast<std::size_t>(k) * 2 + slot) * cameras_ + c];
  }
  PixelCounts total(const SegmentCounts& sums, long matched) const;

  const BodyModel& model_;
  const Rig& rig_;
  const std::vector<SilhouetteMask>* masks_ = nullptr;
  std::size_t cameras_ = 0;
  int max_rows_ = 0;
  ShapeRasterizer rasterizer_;
  std::vector<int> drawn_;        // segments with a shape, in model order
  std::vector<int> drawn_index_;  // per segment: index into drawn_, or -1

  Eigen::VectorXd q_, trial_q_;
  KinematicsData kinematics_;                 // placed at the current pose, or the trial's
  std::vector<Eigen::Isometry3d> saved_world_;  // per moved segment: its pose before the trial
  std::vector<RowSpan> spans_;                // per drawn segment, 2 slots, per camera, max_rows
  std::vector<Footprint> footprints_;         // the same layout
  std::vector<int> slot_;                     // per drawn segment: the current pose's slot
  std::vector<SegmentCounts> segment_counts_, trial_counts_;  // per drawn segment
  SegmentCounts sums_, trial_sums_;
  long matched_ = 0, trial_matched_ = 0;
  PixelCounts counts_;

  bool pending_ = false;
  std::vector<char> moved_flag_;  // per segment, scratch of trial()
  std::vector<int> moved_;        // the trial's moved segments, in model order
  std::vector<int> moved_drawn_;  // their drawn indices
  // The rest of the last trial's moved set, valid until the next reset: R's footprints (per
  // camera, then scratch for the moved ones' chain) and matched(R).
  std::vector<int> rest_of_;  // drawn indices of the moved set it belongs to
  bool rest_valid_ = false;
  std::vector<std::vector<Footprint>> rest_explained_;
  long rest_matched_ = 0;
  long renders_ = 0;
};

}  // namespace mocap
