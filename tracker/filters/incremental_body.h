// The full-body likelihood (full_body.h) kept up to date across poses that differ in a few DOFs,
// for the factored filter's refinement: a trial re-places and re-rasterizes only the segments those
// DOFs move (their subtrees) and counts only them, with exactly the counts
// FullBodyEvaluator::evaluate gives for the same pose.
//
// The full-body counts do not depend on the segments' order: matched = silhouette pixels covered by
// the union of all footprints, outside and area = sums over the footprints. So with the moved
// segments M and the rest R, matched = matched(R) + what M adds over R, the masked chain of M's
// footprints with R's as explained. matched(R) follows from the current pose's counts minus the
// current M's chain over R; it holds while R stands still, which it does for every trial of the
// same DOFs (the refinement tries each DOF both ways, accepted or not), so it is counted once per
// set.
#pragma once

#include <vector>

#include "tracker/filters/worker_pool.h"
#include "tracker/likelihood/likelihood.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/model/kinematics.h"

namespace mocap {

class IncrementalBodyEvaluator {
 public:
  // With a pool of more than one thread, each camera's part of a reset or trial (rasterizing the
  // moved segments, counting them over the rest) runs on its own worker; the counts are integers
  // summed per camera, so they do not depend on the thread count. The pool is borrowed.
  IncrementalBodyEvaluator(const BodyModel& model, const Rig& rig, int points_per_circle,
                           WorkerPool* pool = nullptr);

  // Evaluates the whole body at q against `masks` (kept by reference until the next reset) and
  // makes it the current pose. Drops any pending trial.
  PixelCounts reset(const Eigen::VectorXd& q, const std::vector<SilhouetteMask>& masks);
  // The counts at q, which may differ from the current pose in any DOFs; then accept() makes q the
  // current pose or reject() restores the current one, before the next trial.
  PixelCounts trial(const Eigen::VectorXd& q);
  void accept();
  void reject();
  // Every segment placed at the pending trial's pose, else at the current pose.
  const KinematicsData& kinematics() const { return kinematics_; }

  const PixelCounts& counts() const { return counts_; }
  // The current pose's footprint of every segment with a shape, in camera c (model order).
  void currentFootprints(std::size_t c, std::vector<Footprint>& out) const;
  const Eigen::VectorXd& pose() const { return q_; }
  // Segments rasterized (in all cameras) so far, by resets and trials.
  long renders() const { return renders_; }

 private:
  // Runs fn(camera, rasterizer) for every camera, on the pool's workers if there are several.
  template <typename Fn>
  void forEachCamera(const Fn& fn) {
    if (!pool_ || pool_->size() == 1) {
      for (std::size_t c = 0; c < cameras_; ++c) fn(c, rasterizers_[0]);
      return;
    }
    pool_->parallelFor(static_cast<int>(cameras_), [&](int c, int worker) {
      fn(static_cast<std::size_t>(c), rasterizers_[worker]);
    });
  }
  // Rasterizes drawn segment k at its placed pose into slot `slot` of camera c.
  void draw(int k, std::size_t c, int slot, ShapeRasterizer& rasterizer);
  // Which footprints of the moved drawn segments movedOverRest counts: the trial's, the current
  // pose's just drawn by reset, or the current pose's counted before (recounted on the rows the
  // rest covers only).
  enum class Moved { kTrial, kDrawn, kCurrent };
  // Matched pixels the moved drawn segments add over the rest in camera c; a footprint counted
  // afresh keeps its own counts in footprint_counts_.
  long movedOverRest(std::size_t c, Moved which);
  // Makes camera c's explained footprints of the rest those of the trial's moved set, and returns
  // its part of matched(R): counted directly (rest_direct_) or what the current moved set adds.
  long restFor(std::size_t c);
  // Adds `sign` times drawn segment k's own area and outside pixels in `slot`, over the cameras.
  void addOwnCounts(int k, int slot, long sign, PixelCounts& to) const;
  // The slot of drawn segment k that holds the footprints `which` names.
  int slotOf(int k, Moved which) const { return which == Moved::kTrial ? 1 - slot_[k] : slot_[k]; }
  std::size_t slotIndex(int k, std::size_t c, int slot) const {
    return (static_cast<std::size_t>(k) * 2 + slot) * cameras_ + c;
  }
  Footprint& footprint(int k, std::size_t c, int slot) {
    return footprints_[slotIndex(k, c, slot)];
  }

  const BodyModel& model_;
  const Rig& rig_;
  const std::vector<SilhouetteMask>* masks_ = nullptr;
  std::size_t cameras_ = 0;
  int max_rows_ = 0;
  WorkerPool* pool_;
  std::vector<ShapeRasterizer> rasterizers_;        // one per worker
  std::vector<long> camera_matched_, camera_rest_;  // per camera, scratch of reset and trial()
  std::vector<int> drawn_;                          // segments with a shape, in model order
  std::vector<int> drawn_index_;                    // per segment: index into drawn_, or -1

  Eigen::VectorXd q_, trial_q_;
  KinematicsData kinematics_;                   // placed at the current pose, or the trial's
  std::vector<Eigen::Isometry3d> saved_world_;  // per moved segment: its pose before the trial
  std::vector<RowSpan> spans_;                  // per drawn segment, 2 slots, per camera, max_rows
  std::vector<Footprint> footprints_;           // the same layout
  // The same layout: each footprint's own area and silhouette pixels (no chain), so the current
  // pose's moved set is recounted over a new rest on the rows the rest covers only.
  std::vector<PixelCounts> footprint_counts_;
  std::vector<int> slot_;              // per drawn segment: the current pose's slot
  PixelCounts counts_, trial_counts_;  // the whole body at the current pose, at the trial

  bool pending_ = false;
  std::vector<char> moved_flag_;  // per segment, scratch of trial()
  std::vector<int> moved_;        // the trial's moved segments, in model order
  std::vector<int> moved_drawn_;  // their drawn indices
  // The rest of the last trial's moved set, valid until the next reset: R's footprints (per
  // camera, then scratch for the moved ones' chain) and matched(R).
  std::vector<int> rest_of_;  // drawn indices of the moved set it belongs to
  bool rest_valid_ = false;
  std::vector<std::vector<Footprint>> rest_explained_;
  bool rest_direct_ = false;  // matched(R) counted directly: R is the smaller part
  long rest_matched_ = 0;
  long renders_ = 0;
};

}  // namespace mocap
