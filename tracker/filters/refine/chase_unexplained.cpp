// The chase move: rays through the unexplained blobs, and each leg's knee and ankle moved onto
// them.
#include "tracker/filters/refine/chase_unexplained.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "tracker/likelihood/unexplained.h"
#include "tracker/model/kinematics.h"

namespace mocap {

void chaseUnexplained(const BodyModel& model, const Rig& rig, const std::vector<Leg>& legs,
                      const std::vector<SilhouetteMask>& masks, PoseSearch& search, ChaseData& data,
                      Eigen::VectorXd& q, double& best) {
  // Fixed before measuring: a 5-pixel opening drops the slivers along the edges; a blob counts
  // from 2 % of the camera's silhouette (a forearm's or a shin's share) and 100 pixels.
  constexpr int kOpening = 5;
  constexpr double kMinShare = 0.02;
  constexpr long kMinPixels = 100;
  if (legs.empty() || search.budget() <= 2) return;
  KinematicsData& kin = data.legs.kinematics;
  forwardKinematics(model, kin, q);
  std::vector<Eigen::Vector3d>& joints = data.legs.points;  // per leg: hip, knee, ankle
  joints.clear();
  for (const Leg& leg : legs) {
    const int knee = model.segments[leg.segment].parent;
    for (int s : {model.segments[knee].parent, knee, leg.segment})
      joints.push_back(kin.world[s].translation());
  }
  // The evaluator stands at q (every search before this one ends back at its pose).
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rays;  // origin, unit direction
  for (std::size_t c = 0; c < rig.size(); ++c) {
    search.evaluator().currentFootprints(c, data.footprints);
    const long min_area =
        std::max(kMinPixels, std::lround(kMinShare * static_cast<double>(masks[c].total())));
    const std::vector<UnexplainedBlob> blobs =
        unexplainedBlobs(masks[c], data.footprints.data(), static_cast<int>(data.footprints.size()),
                         min_area, kOpening);
    if (!blobs.empty())
      rays.emplace_back(rig[c].center(), rig[c].backProject(blobs.front().centroid));
  }
  Eigen::VectorXd& tried = data.move.tried;
  Eigen::VectorXd& local = data.move.local;
  double local_value = -INFINITY;
  std::size_t local_leg = 0;
  for (const auto& [origin, direction] : rays) {
    for (std::size_t l = 0; l < legs.size(); ++l) {
      const int segments[2] = {model.segments[legs[l].segment].parent, legs[l].segment};
      for (int j = 0; j < 2 && search.budget() > 2; ++j) {
        const Eigen::Vector3d& joint = joints[3 * l + 1 + j];
        const Eigen::Vector3d target =
            origin + direction * std::max(0.0, direction.dot(joint - origin));
        // World z is up: a knee or ankle above the hip is a blob of the arms or the trunk.
        if (target.z() >= joints[3 * l].z()) continue;
        tried = q;
        moveJointTo(model, data.legs, legs[l], segments[j], target, tried);
        const double value = search.trialScore(tried);
        search.evaluator().reject();
        if (value > local_value) {
          local_value = value;
          local = tried;
          local_leg = l;
        }
      }
    }
  }
  if (local_value == -INFINITY || search.budget() <= 2) return;
  search.trialScore(local);
  search.evaluator().accept();
  // Up to 2 poses per leg angle.
  const std::vector<int>& dofs = legs[local_leg].rotations;
  search.searchAndKeep(dofs, 2 * static_cast<int>(dofs.size()), 0, local, local_value, q, best);
}

}  // namespace mocap
