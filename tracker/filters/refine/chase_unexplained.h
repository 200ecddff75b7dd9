// The refinement's chase move (FilterOptions::refine_unexplained): a leg lost inside the trunk
// explains nothing new and costs nothing, so no local step pulls it out; the blob of silhouette it
// left unexplained says where it went.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "tracker/filters/refine/legs.h"
#include "tracker/filters/refine/pose_search.h"
#include "tracker/likelihood/likelihood.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

// Scratch of chaseUnexplained().
struct ChaseData {
  explicit ChaseData(const BodyModel& model) : legs(model) {}
  LegData legs;
  MoveScratch move;
  std::vector<Footprint> footprints;  // the evaluator's, in one camera
};

// In each camera, the largest blob of silhouette that q (the evaluator's current pose) leaves
// unexplained gives a ray through its centroid; each leg's knee, then ankle, is moved by its hip
// and knee angles to the ray's point nearest it if that point is below the hip, one evaluation
// each. The best of those poses is searched locally on its leg's angles but the facing twists (up
// to 2 poses per angle) and kept in q and `best` if it beats the pose; otherwise the evaluator
// goes back to q.
void chaseUnexplained(const BodyModel& model, const Rig& rig, const std::vector<Leg>& legs,
                      const std::vector<SilhouetteMask>& masks, PoseSearch& search, ChaseData& data,
                      Eigen::VectorXd& q, double& best);

}  // namespace mocap
