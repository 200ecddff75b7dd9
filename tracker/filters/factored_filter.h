// The factored particle filter's class, internal to the filters (makeFactoredFilter in filter.h is
// its public face). Its paper loop is in factored_filter.cpp, the look-ahead a layer may rank by
// in factored_lookahead.cpp, its plan in factored_plan.h and the full-body refinement it runs
// after the layers in refine/refinement.h.
#pragma once

#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tracker/filters/factored_data.h"
#include "tracker/filters/factored_plan.h"
#include "tracker/filters/filter.h"
#include "tracker/filters/refine/refinement.h"

namespace mocap {

class FactoredFilter final : public PoseFilter {
 public:
  // The model, rig and pool are borrowed and must outlive the filter.
  FactoredFilter(const BodyModel& model, const Rig& rig, const FilterOptions& options,
                 WorkerPool& pool);

  std::string name() const override { return "factored"; }
  void setYield(std::function<bool()> newer_frame_waiting) override {
    yield_ = std::move(newer_frame_waiting);
  }
  void reset(const Eigen::VectorXd& q0) override;
  FrameEstimate step(const std::vector<SilhouetteMask>& masks) override;

 private:
  Footprint* candidateFootprints(int i) { return &candidate_footprints_[i * rig_.size()]; }
  RowSpan* candidateSpans(int i, std::size_t camera) {
    return &candidate_spans_[(i * rig_.size() + camera) * max_rows_];
  }

  // Normalizes the carried weights, and places the static segments (identical in every particle)
  // once in the node arena.
  void startFrame(FrameEstimate& estimate);
  int addNode(const Eigen::Isometry3d& pose);
  // Completes the kept particles (sorted best first) with deterministic interval samples of the
  // layer's DOF; the last candidates (those of the weakest particle) are replaced by injected
  // samples over the DOF's whole range.
  int generateCandidates(const FactoredLayer& layer, double& injection_debt);
  // Candidates whose segment lands at the same pose (the same parent segment node and the same
  // values of the segment's DOFs) share one rasterization, and one node if several are kept. This
  // is common: kept particles often agree on the layer's DOF and on their ancestors, and then
  // their samples coincide (two thirds of a hand layer's candidates, half of a human one's).
  void groupSamePoses(const FactoredLayer& layer, int count);
  void evaluateGroup(const FactoredLayer& layer, int g, int count,
                     const std::vector<SilhouetteMask>& masks, int worker);
  // Scores candidate i; `same_pose` is an already placed candidate whose segment pose (and so
  // footprints) it shares, or -1.
  void evaluate(const FactoredLayer& layer, int i, int same_pose,
                const std::vector<SilhouetteMask>& masks, int worker);
  // Keeps the K heaviest candidates (ties to the earlier one, so the result never depends on
  // thread timing) and moves their footprints into the frame's node arena.
  void keepBest(const FactoredLayer& layer, int count);
  void finishFrame(FrameEstimate& estimate);

  // The look-ahead (factored_lookahead.cpp). Sets candidate i's selection, the rank of a layer
  // with a look-ahead: the whole body with the candidate's segment and subtree.
  void rankByLookahead(const FactoredLayer& layer, int i, const std::vector<SilhouetteMask>& masks,
                       WorkerScratch& scratch);
  // Places every segment of parent particle p that is neither placed this frame nor in
  // the layer segment's subtree at its previous relative pose, and counts them after the placed
  // ones, in camera c. The same for all of p's candidates, so done once per parent.
  void placeRest(const FactoredLayer& layer, int p, std::size_t c,
                 const std::vector<SilhouetteMask>& masks, int worker);
  // The descendants of the candidate's segment at their previous relative pose, each counted
  // through the masked chain after the segment itself and the descendants before it.
  PixelCounts lookAhead(int s, const FactoredCandidate& cand, int i,
                        const std::vector<SilhouetteMask>& masks, WorkerScratch& scratch);

  const BodyModel& model_;
  const Rig& rig_;
  FilterOptions options_;
  WorkerPool& pool_;
  std::mt19937_64 rng_;
  std::function<bool()> yield_;  // see PoseFilter::setYield

  const FactoredPlan plan_;
  int max_rows_ = 0;

  std::vector<FactoredParticle> particles_, next_particles_;
  std::vector<FactoredCandidate> candidates_;
  std::vector<RowSpan> candidate_spans_;
  std::vector<Footprint> candidate_footprints_;
  std::vector<PixelCounts> candidate_counts_;  // per candidate and camera
  std::vector<int> order_;
  std::vector<int> pose_groups_;  // per group of same-pose candidates: its first candidate
  std::vector<int> pose_group_;   // per candidate: its group
  std::vector<int> group_node_;   // per group: the node of its first kept candidate, or -1
  std::vector<FactoredNode> nodes_;
  std::vector<Footprint> node_footprints_;
  std::vector<RowSpan> span_arena_;
  std::size_t arena_used_ = 0;
  std::vector<WorkerScratch> scratch_;      // per worker
  std::vector<RestOfBody> rest_;            // per kept particle
  std::unique_ptr<Refinement> refinement_;  // only with a refine share
};

}  // namespace mocap
