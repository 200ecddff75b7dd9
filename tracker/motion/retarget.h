// Mapping real motion capture (BVH skeletons, in metres: see loadBvh) onto the tracker's body
// model: which joint is which model point (joint_map.h), how the axes of the file map onto the
// model's, fitting the body's bone lengths to the subject, and retargeting a BVH motion into DOF
// vectors by inverse kinematics on the corresponding points. This is the ground truth of the
// human-tracking experiments.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/motion.h"

namespace mocap {

// The BVH joint (or End Site) index of every model point, in model point order, by the skeleton's
// joint map (BvhSkeleton::joint_map) or, without one, by its recognised naming (bvh11 or
// cgspeed, joint_map.h). Throws std::runtime_error naming the joints that cannot be mapped.
std::vector<int> correspondingBvhJoints(const BodyModel& model, const BvhSkeleton& skeleton);

// The orthogonal map from the BVH file's axes to the model's: BVH's up (+Y) onto the model
// world's up (+Z), and the subject's rest-pose left (LeftHip - RightHip) and forward (ankle -> toe)
// directions, made horizontal, onto the model's neutral-pose ones, so the subject stands as the
// model stands. It is a proper rotation when the two bodies have the same handedness; if the
// model is the mirror image of a real body it is a reflection (det = -1), which `mirrored` reports.
struct AxisMap {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // model = rotation * bvh
  bool mirrored = false;
};
AxisMap bvhToModelAxes(const BodyModel& model, const BvhSkeleton& skeleton);

// A bone: the rest distance between two model points (or between their CMU joints).
struct BoneLength {
  std::string name;
  double length = 0;  // metres
};
// The fitted bones, in a fixed order: pelvis->hip, hip width, hip->knee, knee->ankle, ankle->toe
// (left and right), pelvis->neck, neck->head_top, shoulder width, shoulder->elbow, elbow->wrist,
// wrist->hand (left and right).
std::vector<BoneLength> modelBoneLengths(const BodyModel& model);
std::vector<BoneLength> subjectBoneLengths(const BodyModel& model, const BvhSkeleton& skeleton);

// The documented way to fit the body to a subject (docs/human.md): a copy of `model` whose bones
// (above) have the subject's rest-pose lengths. Each limb segment is scaled along its bone (child
// offsets, points, cone length, ellipsoid centre and size along its axis); the trunk is scaled
// vertically to the subject's pelvis->neck and shoulder heights and laterally to the hip and
// shoulder widths; the pelvis point moves to where the subject's Hips joint is relative to the
// hip joints; the standing height is set so the fitted feet stand where the model's did. DOFs,
// limits and speeds are unchanged.
BodyModel fitModelToBvh(const BodyModel& model, const BvhSkeleton& skeleton);
// The same fit to any subject's rest pose: `subject` holds, per model point, where the subject has
// it standing as the model stands at its neutral pose (model axes, metres). Throws
// std::invalid_argument unless there is one per model point.
BodyModel fitModelToRestPoints(const BodyModel& model, const std::vector<Eigen::Vector3d>& subject);

// The inverse-kinematics fit of all free DOFs to target point positions (world, metres).
struct IkOptions {
  int max_iterations = 60;
  // Weight of the pull toward `prior` (metres of point error per radian or metre of DOF change):
  // it keeps DOFs that the points barely constrain (twists) where they were.
  double prior_weight = 0.01;
  // retargetBvh: keep every frame's change within the DOFs' speed limits, so the ground truth is
  // a motion the model can perform (what the recording does faster shows up as residual).
  bool respect_speed_limits = true;
};
struct IkResult {
  Eigen::VectorXd q;
  double rms_error = 0;  // metres, over the points
  int iterations = 0;
};
// Projected Levenberg-Marquardt from `start`, every iterate clamped into the joint limits.
IkResult fitPoseToPoints(const BodyModel& model, const std::vector<Eigen::Vector3d>& targets,
                         const Eigen::VectorXd& start, const Eigen::VectorXd& prior,
                         const IkOptions& options = {});

struct SpeedExcess {
  std::string dof;
  int frames = 0;    // output frames whose change from the previous one exceeds max_speed
  double worst = 0;  // largest change in one frame (radians or metres)
  double max_speed = 0;
};

struct RetargetResult {
  Motion motion;                                      // one DOF vector per output frame
  std::vector<double> times;                          // seconds from the first BVH frame
  std::vector<std::vector<Eigen::Vector3d>> targets;  // [frame][point]: CMU points, model axes
  std::vector<std::vector<double>> residual_mm;       // [frame][point]: |model point - CMU point|
  std::vector<SpeedExcess> speed_excess;              // DOFs that exceed their speed limit, if any
  bool mirrored = false;                              // see AxisMap
};

// Retargets a BVH motion onto `fitted` (normally fitModelToBvh's result), resampled by time at
// `rate_hz`: output frame k is at t = k / rate_hz; the CMU joint positions are interpolated
// linearly between the two nearest BVH frames; each frame is then fitted by fitPoseToPoints,
// warm-started from (and pulled toward) the previous frame's solution. The first frame starts
// from the neutral pose with the pelvis on the subject's hips and the yaw of the subject's hips.
// `max_frames` > 0 stops after that many output frames. Speed limits are reported (per output
// frame, as the model defines them), not enforced.
RetargetResult retargetBvh(const BodyModel& fitted, const BvhSkeleton& skeleton,
                           const BvhMotion& motion, double rate_hz = 25, int max_frames = 0,
                           const IkOptions& options = {});

// The number of output frames of a motion of `bvh_frames` frames resampled at `rate_hz`.
int resampledFrameCount(int bvh_frames, double frame_time, double rate_hz);

}  // namespace mocap
