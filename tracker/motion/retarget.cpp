// BVH -> body model: correspondence, axis map, body fitting and inverse-kinematics retargeting.
#include "tracker/motion/retarget.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "tracker/model/kinematics.h"

namespace mocap {

namespace {

int requirePoint(const BodyModel& model, const std::string& name) {
  const int p = model.pointIndex(name);
  if (p < 0)
    throw std::runtime_error("body model '" + model.name + "' has no point '" + name + "'");
  return p;
}

std::vector<Eigen::Vector3d> neutralPoints(const BodyModel& model) {
  KinematicsData data(model);
  forwardKinematics(model, data, model.neutralPose());
  return pointPositions(model, data);
}

// Columns: the body's left, forward and up directions, left and forward made horizontal.
Eigen::Matrix3d bodyFrame(const std::vector<Eigen::Vector3d>& points, const BodyModel& model,
                          const Eigen::Vector3d& up) {
  auto at = [&](const char* name) { return points[requirePoint(model, name)]; };
  const Eigen::Vector3d left = at("l_hip") - at("r_hip");
  const Eigen::Vector3d forward = at("l_toe") - at("l_ankle") + at("r_toe") - at("r_ankle");
  const Eigen::Vector3d l = (left - up * up.dot(left)).normalized();
  const Eigen::Vector3d f = (forward - up * up.dot(forward) - l * l.dot(forward)).normalized();
  Eigen::Matrix3d frame;
  frame << l, f, up;
  return frame;
}

// Scales everything segment `s` carries along the unit direction `axis` (segment frame) by
// `factor`: its children's offsets, its points and its shape; the thickness across is kept.
void scaleSegmentAlong(BodyModel& model, int s, const Eigen::Vector3d& axis, double factor) {
  auto scale = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d {
    return v + (factor - 1) * axis.dot(v) * axis;
  };
  for (Segment& child : model.segments)
    if (child.parent == s) child.offset = scale(child.offset);
  for (BodyPoint& p : model.points)
    if (p.segment == s) p.local = scale(p.local);
  Shape& shape = model.segments[s].shape;
  if (shape.type == ShapeType::kTruncatedCone) {
    const Eigen::Vector3d along = scale(shape.axis * shape.length);
    shape.length = along.norm();
    shape.axis = along.normalized();
  } else if (shape.type == ShapeType::kEllipsoid) {
    // Semi-axes lie along the frame axes: each grows with the share of `axis` it carries.
    shape.center = scale(shape.center);
    for (int k = 0; k < 3; ++k) shape.radii[k] *= 1 + (factor - 1) * std::abs(axis[k]);
  }
}

// The offset of the single child segment of `s` whose origin carries point `child_point`.
Segment& childCarrying(BodyModel& model, int s, int child_point) {
  Segment& child = model.segments[model.points[child_point].segment];
  if (&child == &model.segments[s] || child.parent != s ||
      !model.points[child_point].local.isZero())
    throw std::runtime_error(
        "body model '" + model.name + "': point '" + model.points[child_point].name +
        "' is not the origin of a child segment of '" + model.segments[s].name + "'");
  return child;
}

// Fits one limb segment that ends where its child segment (carrying `distal`) starts.
void fitLimbSegment(BodyModel& model, int proximal, int distal, double length) {
  const int s = model.points[proximal].segment;
  const Eigen::Vector3d bone = childCarrying(model, s, distal).offset;
  scaleSegmentAlong(model, s, bone.normalized(), length / bone.norm());
}

}  // namespace

std::vector<int> correspondingBvhJoints(const BodyModel& model, const BvhSkeleton& skeleton) {
  const JointMap& map = skeleton.joint_map ? *skeleton.joint_map : recogniseJointMap(skeleton);
  std::vector<std::string> model_points;
  for (const BodyPoint& p : model.points) model_points.push_back(p.name);
  checkJointMap(map, skeleton, model_points);
  std::vector<int> joints(model.points.size(), -1);
  for (const JointCorrespondence& c : map.joints)
    joints[model.pointIndex(c.model_point)] = skeleton.jointIndex(c.bvh_joint);
  return joints;
}

AxisMap bvhToModelAxes(const BodyModel& model, const BvhSkeleton& skeleton) {
  const std::vector<int> joints = correspondingBvhJoints(model, skeleton);
  const std::vector<Eigen::Vector3d> rest = bvhRestPositions(skeleton);
  std::vector<Eigen::Vector3d> subject;
  for (int j : joints) subject.push_back(rest[j]);
  AxisMap map;
  map.rotation = bodyFrame(neutralPoints(model), model, Eigen::Vector3d::UnitZ()) *
                 bodyFrame(subject, model, Eigen::Vector3d::UnitY()).transpose();
  map.mirrored = map.rotation.determinant() < 0;
  return map;
}

namespace {

struct BoneDef {
  const char* name;
  const char* from;
  const char* to;
};

const BoneDef kBones[] = {
    {"l_pelvis_hip", "pelvis", "l_hip"},      {"r_pelvis_hip", "pelvis", "r_hip"},
    {"hip_width", "l_hip", "r_hip"},          {"l_thigh", "l_hip", "l_knee"},
    {"l_shin", "l_knee", "l_ankle"},          {"l_foot", "l_ankle", "l_toe"},
    {"r_thigh", "r_hip", "r_knee"},           {"r_shin", "r_knee", "r_ankle"},
    {"r_foot", "r_ankle", "r_toe"},           {"pelvis_neck", "pelvis", "neck"},
    {"neck_head_top", "neck", "head_top"},    {"shoulder_width", "l_shoulder", "r_shoulder"},
    {"l_upper_arm", "l_shoulder", "l_elbow"}, {"l_forearm", "l_elbow", "l_wrist"},
    {"l_hand", "l_wrist", "l_hand"},          {"r_upper_arm", "r_shoulder", "r_elbow"},
    {"r_forearm", "r_elbow", "r_wrist"},      {"r_hand", "r_wrist", "r_hand"},
};

std::vector<BoneLength> boneLengths(const BodyModel& model,
                                    const std::vector<Eigen::Vector3d>& points) {
  std::vector<BoneLength> bones;
  for (const BoneDef& b : kBones)
    bones.push_back(
        {b.name, (points[requirePoint(model, b.to)] - points[requirePoint(model, b.from)]).norm()});
  return bones;
}

std::vector<Eigen::Vector3d> subjectRestPoints(const BodyModel& model, const BvhSkeleton& skeleton,
                                               const Eigen::Matrix3d& axes) {
  const std::vector<int> joints = correspondingBvhJoints(model, skeleton);
  const std::vector<Eigen::Vector3d> rest = bvhRestPositions(skeleton);
  std::vector<Eigen::Vector3d> points;
  for (int j : joints) points.push_back(axes * rest[j]);
  return points;
}

}  // namespace

std::vector<BoneLength> modelBoneLengths(const BodyModel& model) {
  return boneLengths(model, neutralPoints(model));
}

std::vector<BoneLength> subjectBoneLengths(const BodyModel& model, const BvhSkeleton& skeleton) {
  return boneLengths(model, subjectRestPoints(model, skeleton, Eigen::Matrix3d::Identity()));
}

BodyModel fitModelToBvh(const BodyModel& model, const BvhSkeleton& skeleton) {
  const AxisMap axes = bvhToModelAxes(model, skeleton);
  return fitModelToRestPoints(model, subjectRestPoints(model, skeleton, axes.rotation));
}

BodyModel fitModelToRestPoints(const BodyModel& model,
                               const std::vector<Eigen::Vector3d>& subject) {
  if (subject.size() != model.points.size())
    throw std::invalid_argument("fitting body model '" + model.name +
                                "': " + std::to_string(subject.size()) + " rest points for its " +
                                std::to_string(model.points.size()));
  auto point = [&](const char* name) { return requirePoint(model, name); };
  auto length = [&](const char* a, const char* b) {
    return (subject[point(b)] - subject[point(a)]).norm();
  };
  BodyModel fitted = model;

  for (const char* side : {"l_", "r_"}) {
    auto name = [&](const char* joint) { return std::string(side) + joint; };
    auto p = [&](const char* joint) { return point(name(joint).c_str()); };
    auto len = [&](const char* a, const char* b) {
      return length(name(a).c_str(), name(b).c_str());
    };
    fitLimbSegment(fitted, p("hip"), p("knee"), len("hip", "knee"));
    fitLimbSegment(fitted, p("knee"), p("ankle"), len("knee", "ankle"));
    fitLimbSegment(fitted, p("shoulder"), p("elbow"), len("shoulder", "elbow"));
    // The foot ends at a point on its own segment.
    const BodyPoint& toe = fitted.points[p("toe")];
    scaleSegmentAlong(fitted, toe.segment, toe.local.normalized(),
                      len("ankle", "toe") / toe.local.norm());
    // The forearm carries the wrist and the hand on one line from the elbow.
    const BodyPoint& hand = fitted.points[p("hand")];
    const Eigen::Vector3d forearm_axis = hand.local.normalized();
    const double wrist_length = len("elbow", "wrist");
    const double hand_length = wrist_length + len("wrist", "hand");
    scaleSegmentAlong(fitted, hand.segment, forearm_axis, hand_length / hand.local.norm());
    fitted.points[p("wrist")].local = forearm_axis * wrist_length;
  }
  {
    const BodyPoint& head_top = fitted.points[point("head_top")];
    scaleSegmentAlong(fitted, head_top.segment, head_top.local.normalized(),
                      length("neck", "head_top") / head_top.local.norm());
  }

  // Trunk. The pelvis frame is the world frame at the neutral pose; its origin lies between the
  // hip joints, its lateral axis through them, its up axis toward the chest.
  const int pelvis = fitted.points[point("pelvis")].segment;
  const int head_segment = fitted.points[point("neck")].segment;
  const int chest_segment = fitted.segments[head_segment].parent;
  Segment& l_thigh = fitted.segments[fitted.points[point("l_hip")].segment];
  Segment& r_thigh = fitted.segments[fitted.points[point("r_hip")].segment];
  if (l_thigh.parent != pelvis || r_thigh.parent != pelvis ||
      fitted.segments[chest_segment].parent != pelvis)
    throw std::runtime_error("body model '" + model.name +
                             "': expected the thighs and the chest to hang from the pelvis");
  // A model whose hip joints hang below its root is first re-rooted between them, where the fit
  // puts the root, so its points and shapes stay where they were.
  moveSegmentOrigin(fitted, pelvis, 0.5 * (l_thigh.offset + r_thigh.offset));
  const Eigen::Vector3d lateral = (l_thigh.offset - r_thigh.offset).normalized();
  const Eigen::Vector3d up = fitted.segments[chest_segment].offset.normalized();

  // Hips: lateral offsets as the subject's; the pelvis point goes where the subject's Hips joint
  // sits relative to the hip joints (CMU's root is about 9 cm above them).
  const Eigen::Vector3d to_l_hip = subject[point("l_hip")] - subject[point("pelvis")];
  const Eigen::Vector3d to_r_hip = subject[point("r_hip")] - subject[point("pelvis")];
  const Eigen::Vector3d to_hip_centre = 0.5 * (to_l_hip + to_r_hip);
  const Eigen::Vector3d pelvis_local = lateral * lateral.dot(to_hip_centre) - to_hip_centre;
  const double hip_width = lateral.dot(to_l_hip - to_r_hip);

  // Chest and head offsets: the neck straight above the hip centre, at the subject's distance
  // from the pelvis point.
  const Eigen::Vector3d pelvis_across = pelvis_local - up * up.dot(pelvis_local);
  const double pelvis_neck = length("pelvis", "neck");
  if (pelvis_neck <= pelvis_across.norm())
    throw std::runtime_error("BVH skeleton: the neck is closer to the Hips than the hips are");
  const double neck_height =
      up.dot(pelvis_local) + std::sqrt(pelvis_neck * pelvis_neck - pelvis_across.squaredNorm());
  const double trunk_scale = neck_height / up.dot(fitted.segments[chest_segment].offset +
                                                  fitted.segments[head_segment].offset);
  scaleSegmentAlong(fitted, pelvis, up, trunk_scale);
  scaleSegmentAlong(fitted, pelvis, lateral, hip_width / (l_thigh.offset - r_thigh.offset).norm());
  scaleSegmentAlong(fitted, chest_segment, up, trunk_scale);
  l_thigh.offset = lateral * lateral.dot(to_l_hip);
  r_thigh.offset = lateral * lateral.dot(to_r_hip);
  fitted.points[point("pelvis")].local = pelvis_local;

  // Shoulders: at the subject's shoulder height above the hip line, the subject's width apart.
  Segment& l_upper_arm = fitted.segments[fitted.points[point("l_shoulder")].segment];
  Segment& r_upper_arm = fitted.segments[fitted.points[point("r_shoulder")].segment];
  if (l_upper_arm.parent != chest_segment || r_upper_arm.parent != chest_segment)
    throw std::runtime_error("body model '" + model.name +
                             "': expected the upper arms to hang from the chest");
  const Eigen::Vector3d hip_centre = 0.5 * (subject[point("l_hip")] + subject[point("r_hip")]);
  const double shoulder_height =
      up.dot(0.5 * (subject[point("l_shoulder")] + subject[point("r_shoulder")]) - hip_centre) -
      up.dot(fitted.segments[chest_segment].offset);
  const double old_shoulder_width = (l_upper_arm.offset - r_upper_arm.offset).norm();
  const double shoulder_width = length("l_shoulder", "r_shoulder");
  scaleSegmentAlong(fitted, chest_segment, lateral, shoulder_width / old_shoulder_width);
  l_upper_arm.offset = lateral * (shoulder_width / 2) + up * shoulder_height;
  r_upper_arm.offset = -lateral * (shoulder_width / 2) + up * shoulder_height;

  // Standing height: the fitted ankles at the height the model's ankles had.
  auto ankle_height = [&](const BodyModel& m) {
    const std::vector<Eigen::Vector3d> points = neutralPoints(m);
    return 0.5 * up.dot(points[point("l_ankle")] + points[point("r_ankle")]);
  };
  fitted.segments[pelvis].offset -= up * (ankle_height(fitted) - ankle_height(model));
  return fitted;
}

IkResult fitPoseToPoints(const BodyModel& model, const std::vector<Eigen::Vector3d>& targets,
                         const Eigen::VectorXd& start, const Eigen::VectorXd& prior,
                         const IkOptions& options) {
  std::vector<int> free;
  for (std::size_t d = 0; d < model.dofs.size(); ++d)
    if (model.dofs[d].isFree()) free.push_back(static_cast<int>(d));
  const int n = static_cast<int>(free.size());
  const int point_rows = 3 * static_cast<int>(targets.size());
  KinematicsData data(model);

  // Residuals: point errors (metres), then the weighted pull of each free DOF toward the prior.
  auto residuals = [&](const Eigen::VectorXd& q, Eigen::VectorXd& r) {
    forwardKinematics(model, data, q);
    for (std::size_t i = 0; i < targets.size(); ++i) {
      const BodyPoint& p = model.points[i];
      r.segment<3>(3 * static_cast<long>(i)) = data.world[p.segment] * p.local - targets[i];
    }
    for (int k = 0; k < n; ++k)
      r[point_rows + k] = options.prior_weight * (q[free[k]] - prior[free[k]]);
  };

  Eigen::VectorXd q = start;
  clampToLimits(model, q);
  Eigen::VectorXd r(point_rows + n), r_trial(point_rows + n);
  Eigen::MatrixXd jacobian(point_rows + n, n);
  residuals(q, r);
  double cost = r.squaredNorm();
  double damping = -1;
  constexpr double kStep = 1e-6;
  int iteration = 0;
  for (; iteration < options.max_iterations; ++iteration) {
    for (int k = 0; k < n; ++k) {
      Eigen::VectorXd q_step = q;
      q_step[free[k]] += kStep;
      residuals(q_step, r_trial);
      jacobian.col(k) = (r_trial - r) / kStep;
    }
    const Eigen::MatrixXd normal = jacobian.transpose() * jacobian;
    const Eigen::VectorXd gradient = jacobian.transpose() * r;
    if (damping < 0) damping = 1e-3 * normal.diagonal().maxCoeff();
    // Projection: a DOF held at a limit by a gradient pointing outward stays out of the step.
    std::vector<int> moving;
    for (int k = 0; k < n; ++k) {
      const Dof& dof = model.dofs[free[k]];
      const double v = q[free[k]];
      if ((v <= dof.min && gradient[k] > 0) || (v >= dof.max && gradient[k] < 0)) continue;
      moving.push_back(k);
    }
    const int m = static_cast<int>(moving.size());
    Eigen::MatrixXd reduced(m, m);
    Eigen::VectorXd reduced_gradient(m);
    for (int a = 0; a < m; ++a) {
      reduced_gradient[a] = gradient[moving[a]];
      for (int b = 0; b < m; ++b) reduced(a, b) = normal(moving[a], moving[b]);
    }
    bool improved = false;
    double decrease = 0;
    for (int attempt = 0; attempt < 12 && !improved; ++attempt) {
      Eigen::MatrixXd damped = reduced;
      damped.diagonal().array() += damping;
      const Eigen::VectorXd step = damped.ldlt().solve(-reduced_gradient);
      Eigen::VectorXd q_trial = q;
      for (int a = 0; a < m; ++a) q_trial[free[moving[a]]] += step[a];
      clampToLimits(model, q_trial);
      residuals(q_trial, r_trial);
      const double trial_cost = r_trial.squaredNorm();
      if (trial_cost < cost) {
        decrease = cost - trial_cost;
        q = q_trial;
        r = r_trial;
        cost = trial_cost;
        damping = std::max(damping / 3, 1e-12);
        improved = true;
      } else {
        damping *= 4;
      }
    }
    if (!improved || decrease < 1e-12 * (1 + cost)) break;
  }
  IkResult result;
  result.q = q;
  result.iterations = iteration;
  result.rms_error = targets.empty() ? 0 : r.head(point_rows).norm() / std::sqrt(targets.size());
  return result;
}

int resampledFrameCount(int bvh_frames, double frame_time, double rate_hz) {
  if (bvh_frames <= 0) return 0;
  const double duration = (bvh_frames - 1) * frame_time;
  return static_cast<int>(std::floor(duration * rate_hz + 1e-9)) + 1;
}

namespace {

// The first frame's start: neutral pose, pelvis origin on the subject's hip centre, facing as the
// subject's hips face.
Eigen::VectorXd initialGuess(const BodyModel& model, const std::vector<Eigen::Vector3d>& targets) {
  Eigen::VectorXd q = model.neutralPose();
  const int l_hip = requirePoint(model, "l_hip"), r_hip = requirePoint(model, "r_hip");
  const std::vector<Eigen::Vector3d> neutral = neutralPoints(model);
  const Eigen::Vector3d subject_left = targets[l_hip] - targets[r_hip];
  const Eigen::Vector3d model_left = neutral[l_hip] - neutral[r_hip];
  const double yaw =
      std::atan2(model_left.x() * subject_left.y() - model_left.y() * subject_left.x(),
                 model_left.head<2>().dot(subject_left.head<2>()));
  const Eigen::Vector3d hip_shift =
      0.5 * (targets[l_hip] + targets[r_hip]) - 0.5 * (neutral[l_hip] + neutral[r_hip]);
  for (int d : model.segments[0].dofs) {
    const Dof& dof = model.dofs[d];
    if (dof.type == DofType::kTranslation) {
      q[d] += hip_shift.dot(dof.axis);
    } else if (std::abs(dof.axis.z()) > 0.99) {
      q[d] = yaw * (dof.axis.z() > 0 ? 1 : -1);
    }
  }
  clampToLimits(model, q);
  return q;
}

}  // namespace

RetargetResult retargetBvh(const BodyModel& fitted, const BvhSkeleton& skeleton,
                           const BvhMotion& motion, double rate_hz, int max_frames,
                           const IkOptions& options) {
  if (!(rate_hz > 0)) throw std::invalid_argument("retargetBvh: the rate must be positive");
  const std::vector<int> joints = correspondingBvhJoints(fitted, skeleton);
  const AxisMap axes = bvhToModelAxes(fitted, skeleton);
  const int bvh_frames = static_cast<int>(motion.frames.size());
  int frames = resampledFrameCount(bvh_frames, motion.frame_time, rate_hz);
  if (max_frames > 0) frames = std::min(frames, max_frames);

  RetargetResult result;
  result.mirrored = axes.mirrored;
  KinematicsData data(fitted);
  Eigen::VectorXd previous;
  for (int k = 0; k < frames; ++k) {
    const double t = k / rate_hz;
    const double position = std::min(t / motion.frame_time, bvh_frames - 1.0);
    const int before = static_cast<int>(std::floor(position));
    const int after = std::min(before + 1, bvh_frames - 1);
    const double blend = position - before;
    const std::vector<Eigen::Vector3d> a = bvhJointPositions(skeleton, motion.frames[before]);
    const std::vector<Eigen::Vector3d> b = bvhJointPositions(skeleton, motion.frames[after]);
    std::vector<Eigen::Vector3d> targets;
    for (int j : joints) targets.push_back(axes.rotation * ((1 - blend) * a[j] + blend * b[j]));

    IkResult ik;
    if (k == 0) {
      const Eigen::VectorXd guess = initialGuess(fitted, targets);
      IkOptions first = options;
      first.max_iterations = 20 * options.max_iterations;  // from far away, not from last frame
      ik = fitPoseToPoints(fitted, targets, guess, guess, first);
    } else if (options.respect_speed_limits) {
      BodyModel reachable = fitted;  // this frame's limits: one speed limit around the last pose
      for (std::size_t d = 0; d < reachable.dofs.size(); ++d) {
        Dof& dof = reachable.dofs[d];
        if (!dof.isFree()) continue;
        const auto [lo, hi] = proposalInterval(fitted.dofs[d], previous[static_cast<long>(d)]);
        dof.min = lo;
        dof.max = hi;
      }
      ik = fitPoseToPoints(reachable, targets, previous, previous, options);
    } else {
      ik = fitPoseToPoints(fitted, targets, previous, previous, options);
    }
    previous = ik.q;

    forwardKinematics(fitted, data, ik.q);
    const std::vector<Eigen::Vector3d> fitted_points = pointPositions(fitted, data);
    std::vector<double> residual;
    for (std::size_t p = 0; p < targets.size(); ++p)
      residual.push_back(1000 * (fitted_points[p] - targets[p]).norm());
    result.motion.push_back(ik.q);
    result.times.push_back(t);
    result.targets.push_back(std::move(targets));
    result.residual_mm.push_back(std::move(residual));
  }

  for (std::size_t d = 0; d < fitted.dofs.size(); ++d) {
    SpeedExcess excess{fitted.dofs[d].name, 0, 0, fitted.dofs[d].max_speed};
    for (std::size_t k = 1; k < result.motion.size(); ++k) {
      const double change = std::abs(result.motion[k][d] - result.motion[k - 1][d]);
      excess.worst = std::max(excess.worst, change);
      if (change > excess.max_speed + 1e-9) ++excess.frames;  // not rounding at the limit
    }
    if (excess.frames > 0) result.speed_excess.push_back(excess);
  }
  return result;
}

}  // namespace mocap
