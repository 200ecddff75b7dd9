// The articulated body model: an immutable tree of segments, each moved by a joint of 0-6 DOFs
// (rotations about or translations along fixed axes) and drawn as a truncated cone or an ellipsoid.
// Loaded once from YAML; everything that changes per pose lives in data objects (kinematics.h).
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

namespace mocap {

enum class DofType { kRotation, kTranslation };

struct Dof {
  std::string name;
  DofType type = DofType::kRotation;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  // unit, in the segment's joint frame
  double min = 0;                                   // radians or metres
  double max = 0;
  double max_speed = 0;  // largest change in one frame (radians or metres per frame)
  int segment = -1;      // the segment this DOF moves
  // A DOF whose limits coincide is frozen: the filters neither sample nor count it.
  bool isFree() const { return max > min; }
};

// The interval the filters' proposal samples for `dof` around `value`: +-max_speed, clipped to
// the limits (the only dynamics the model has).
inline std::pair<double, double> proposalInterval(const Dof& dof, double value) {
  return {std::max(dof.min, value - dof.max_speed), std::min(dof.max, value + dof.max_speed)};
}

enum class ShapeType { kNone, kTruncatedCone, kEllipsoid };

struct Shape {
  ShapeType type = ShapeType::kNone;
  // Truncated cone: from the joint origin along `axis` for `length`, radius_start at the joint,
  // radius_end at the far end.
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  double length = 0;
  double radius_start = 0;
  double radius_end = 0;
  // Ellipsoid: centre in the segment frame, semi-axes along the segment frame axes.
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d radii = Eigen::Vector3d::Zero();
};

struct Segment {
  std::string name;
  int parent = -1;                                   // -1 for the root
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // joint origin in the parent's frame
  std::vector<int> dofs;  // indices into BodyModel::dofs, applied in order
  Shape shape;
};

// A named 3D point carried by a segment (a joint centre or an end site): what errors are measured
// on.
struct BodyPoint {
  std::string name;
  int segment = -1;
  Eigen::Vector3d local = Eigen::Vector3d::Zero();
};

// A named pose the body is often seen in (a person mid-stride, crouching). The DOFs it does not
// list hold their neutral value. Tracking a subject it is not given a pose of, the tracker tries
// the neutral pose and each stance (tracker/search/acquire.h).
struct Stance {
  std::string name;
  std::vector<std::pair<int, double>> dofs;  // DOF index and value (radians or metres)
};

class BodyModel {
 public:
  std::string name;
  std::vector<Segment> segments;  // parents always precede their children
  std::vector<Dof> dofs;          // in segment order: the DBN's hidden-variable order
  std::vector<BodyPoint> points;
  std::vector<std::string> gait_dofs;  // optional subset: the DOFs gait is based on (paper §8.4)
  // Optional: the twists that turn the legs about the body's long axis at the hips (the human's
  // r_hip_twist, l_hip_twist). Their mean, each signed by its axis against the first's, is how far
  // the pelvis faces away from the legs; the tracker's facing prior keeps it small
  // (FilterOptions::refine_facing_prior).
  std::vector<std::string> facing_twists;
  // Optional: segments whose joint stays planted where it is when the tracker's refinement moves
  // the pelvis (the human's r_foot, l_foot): it re-solves the rotations of the two segments above
  // each (hip and knee), other than facing twists (FilterOptions::refine_plant).
  std::vector<std::string> feet;
  // `kind: person` in the file: the body is a person's, so a daemon tracking it starts from the
  // tracker settings measured on people (TrackerSettings::forPeople) rather than the hand's.
  bool person = false;
  std::vector<Stance> stances;  // optional, besides the neutral pose
  // Optional (`fit_pose` in the file, DOF values as a stance's): the pose a subject is asked to
  // stand in while the body is fitted to it from the cameras (tracker/search/body_size.h); the
  // human's is an A-pose, the arms 45 degrees out, so the cameras see their length.
  std::optional<Stance> fit_pose;
  // The camera rate (Hz) the DOFs' max_speed values are per frame of: `frame_rate` in the file,
  // 25 (the paper's rate) when absent. atFrameRate rescales a model to another rate.
  double frame_rate = 25;

  int segmentIndex(const std::string& segment_name) const;  // -1 if absent
  int dofIndex(const std::string& dof_name) const;          // -1 if absent
  int pointIndex(const std::string& point_name) const;      // -1 if absent
  // The DOF vector with every DOF at the nearest in-range value to zero.
  Eigen::VectorXd neutralPose() const;
  // The neutral pose with the stance's DOFs set.
  Eigen::VectorXd stancePose(const Stance& stance) const;
  // True if segment `s` never moves (it and all its ancestors have no free DOFs).
  bool isStatic(int s) const;
};

// A copy of `model` in which every DOF not named in `free_dofs` is frozen at its value in `pose`.
// Throws std::invalid_argument for an unknown name.
BodyModel freezeAllBut(const BodyModel& model, const std::vector<std::string>& free_dofs,
                       const Eigen::VectorXd& pose);

// A copy of `model` whose speed limits are per frame at `hz`: every max_speed scaled by
// model.frame_rate / hz, so a body tracked at 50 Hz may move half as far per frame as at 25 Hz.
// Throws std::invalid_argument unless hz is positive and finite.
BodyModel atFrameRate(const BodyModel& model, double hz);

// A copy of `model` uniformly `factor` times as large: every offset (the root's standing height
// included), shape and point. DOFs are unchanged, so a pose means the same angles and the same
// root displacement on either, and both stand on the floor at the neutral pose. How a body is
// fitted to a subject's height (tracker/search/body_size.h). Throws std::invalid_argument unless
// factor is positive and finite.
BodyModel scaledBodyModel(const BodyModel& model, double factor);
// Moves segment `segment`'s origin by `shift` (in its frame at the neutral pose), its children,
// points and ellipsoid staying where they were: the same body, turned by its DOFs about another
// point. A cone starts at the origin, so it moves with it.
void moveSegmentOrigin(BodyModel& model, int segment, const Eigen::Vector3d& shift);

// Parses a body model from YAML text. `source` names the file in error messages. Throws
// std::runtime_error with "<source>:<line>: <field path>: <reason>" on any bad input.
BodyModel parseBodyModel(const std::string& yaml_text, const std::string& source);
BodyModel loadBodyModel(const std::string& path);
// The model as YAML that parseBodyModel reads back to the same model (to rounding in the last bit
// of angles, which the file holds in degrees): how a session stores the body it was tracked with.
std::string formatBodyModel(const BodyModel& model);

}  // namespace mocap
