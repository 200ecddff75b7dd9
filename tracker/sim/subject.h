// Simulated subjects: people whose shape and clothes are not the tracker's body. A subject is a
// smooth closed surface (ellipsoids and round cones, i.e. capsules with unequal ends, plus
// flat-hemmed skirts and coats) with its own proportions, drawn from a seed the tracker never
// reads, and posed by the world joint positions of a motion-capture skeleton (or of a body model at
// a pose). Rendering is in subject_render.h.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/matx.hpp>

#include "tracker/model/body_model.h"
#include "tracker/model/kinematics.h"

namespace mocap {

enum class LowerGarment { kTrousers, kLooseTrousers, kSkirt, kDress };

// What the subject wears; colours are BGR.
struct Clothing {
  LowerGarment lower = LowerGarment::kTrousers;
  bool coat = false;       // a coat to mid-thigh over the top, with thick sleeves
  bool long_hair = false;  // hair down to the shoulder blades
  bool shoes = true;       // false: barefoot
  cv::Vec3b skin{120, 150, 200}, hair{30, 40, 60}, top{170, 90, 60}, bottom{60, 50, 40},
      coat_colour{40, 70, 110}, shoe_colour{25, 25, 25};
};

// A subject's body. Lengths are the skeleton's, between joint centres; the factors multiply the
// average adult's proportions (fractions of the height).
struct SubjectParams {
  double height = 1.75;  // metres, floor to crown standing (without hair and shoes): 1.50-1.95
  double girth = 1.0;    // slim 0.85 to heavy 1.35: the body's radii, the trunk's the most
  // Limb and trunk lengths relative to the height, 0.9-1.1 each.
  double thigh = 1, shin = 1, upper_arm = 1, forearm = 1, trunk = 1;
  double shoulder_width = 1;  // shoulder joint spacing, 0.9-1.1 of 0.22 x height
  double hip_width = 1;       // hip joint spacing, 0.9-1.1 of 0.105 x height
  Clothing clothing;
};

// A subject drawn from `seed`: uniform height, girth and factors in the ranges above, clothes
// (lower garment, coat, hair, shoes) and colours. Different seeds give different people.
SubjectParams drawSubjectParams(uint64_t seed);

// The joints a subject is posed by: the human body model's 19 points (tracker/models/human.yaml),
// which the CMU skeleton's joints map onto (tracker/motion/retarget.h).
enum SubjectJoint : int {
  kPelvis,
  kNeck,
  kHeadTop,
  kRHip,
  kRKnee,
  kRAnkle,
  kRToe,
  kLHip,
  kLKnee,
  kLAnkle,
  kLToe,
  kRShoulder,
  kRElbow,
  kRWrist,
  kRHand,
  kLShoulder,
  kLElbow,
  kLWrist,
  kLHand,
  kSubjectJointCount
};
// The model point names of the joints, in SubjectJoint order ("pelvis", "neck", "r_hip", ...).
extern const std::array<const char*, kSubjectJointCount> kSubjectJointNames;
using SubjectJoints = std::array<Eigen::Vector3d, kSubjectJointCount>;  // world, metres, Z up
// The joint that joint `joint` hangs from (-1 for the pelvis): neck and hips from the pelvis,
// shoulders and head top from the neck, and down each limb.
int subjectJointParent(int joint);

// The joints among `points` (world positions in model point order, as pointPositions gives).
// Throws std::invalid_argument naming a joint the model has no point for.
SubjectJoints subjectJointsFromPoints(const BodyModel& model,
                                      const std::vector<Eigen::Vector3d>& points);
// The joints of `model` at pose `q`.
SubjectJoints subjectJointsAt(const BodyModel& model, const Eigen::VectorXd& q);
// The world rotation of the segment carrying `model`'s pelvis point, placed by `kinematics`: how
// its pelvis is turned (identity at the neutral pose of a body whose root stands unturned), the
// pelvis_turn a Subject posed by the model takes.
Eigen::Matrix3d pelvisTurnAt(const BodyModel& model, const KinematicsData& kinematics);
// `joints` as model points, in model point order: the truth to score a tracked `model` against.
// Points that are not joints (none on the human model) are left at zero.
std::vector<Eigen::Vector3d> modelPointsFromJoints(const BodyModel& model,
                                                   const SubjectJoints& joints);

// The surface materials, each a colour of the clothing.
enum class SubjectMaterial : uint8_t { kSkin, kHair, kTop, kBottom, kCoat, kShoe };

// One convex piece of the surface: a unit primitive in a local frame, placed by an affine map
// (world = origin + linear * local), so round pieces become elliptic ones.
struct SubjectPrimitive {
  enum class Kind : uint8_t {
    kEllipsoid,  // the unit sphere
    kRoundCone,  // hull of spheres radius0 at 0 and radius1 at (0, 0, length)
    kFrustum,    // hull of discs radius0 at z = 0 and radius1 at z = length (flat ends)
  };
  Kind kind = Kind::kEllipsoid;
  SubjectMaterial material = SubjectMaterial::kSkin;
  Eigen::Matrix3d linear = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double length = 0, radius0 = 1, radius1 = 1;
  // The limb piece's bone, by the joint it ends at (kLWrist: the forearm), the head's kHeadTop;
  // -1 for the trunk and garments. Lets a renderer leave a limb out.
  int bone = -1;
};

// A subject in one pose: its joints (the truth: the clothes do not move them) and its surface.
struct PosedSubject {
  SubjectJoints joints;
  std::vector<SubjectPrimitive> primitives;
  Eigen::Vector3d chest = Eigen::Vector3d::Zero();  // a point on the front of the chest
  const Clothing* clothing = nullptr;               // the Subject's
};

class Subject {
 public:
  // `driver_rest`: the driving skeleton's joints standing at rest, feet on the floor (z = 0),
  // e.g. subjectJointsAt(model, model.neutralPose()). The subject keeps the driver's limb and
  // spine directions with its own bone lengths, and its own hip and shoulder joints, placed in the
  // driver's pelvis and chest frames; its pelvis height scales with the driver's, so it stands on
  // the floor where the driver stands.
  Subject(const SubjectParams& params, const SubjectJoints& driver_rest);

  const SubjectParams& params() const { return params_; }
  Clothing& clothing() { return params_.clothing; }  // settable between poses
  // The subject's own joints when the driver stands at rest (its crown at params().height).
  const SubjectJoints& rest() const { return rest_; }

  // Poses the subject as the driver's joints `driver` are. Thread-safe (const). The subject's hips
  // turn with the driver's pelvis: by `pelvis_turn` where the driver knows it (its pelvis's
  // rotation, identity as it stands at rest: a body model's root segment's world rotation), else
  // by the driver's hip and pelvis joints, or by its spine where those are in line (a body whose
  // hips are level with its pelvis point, which then does not turn them exactly with it).
  void pose(const SubjectJoints& driver, PosedSubject& out,
            const Eigen::Matrix3d* pelvis_turn = nullptr) const;
  SubjectJoints retarget(const SubjectJoints& driver,
                         const Eigen::Matrix3d* pelvis_turn = nullptr) const;
  // Posed by body model `model` as `kinematics` places it: its joints and its pelvis's turn.
  void pose(const BodyModel& model, const KinematicsData& kinematics, PosedSubject& out) const;

 private:
  void addTrunkAndHead(const SubjectJoints& j, PosedSubject& out) const;
  void addLimbs(const SubjectJoints& j, PosedSubject& out) const;
  void addGarments(const SubjectJoints& j, PosedSubject& out) const;

  SubjectParams params_;
  std::array<double, kSubjectJointCount> bone_length_{};  // to each joint from its parent
  // The hips from the pelvis and the shoulders from the neck, in the driver's girdle frames (see
  // girdleFrame in subject.cpp); zero for the other joints.
  SubjectJoints girdle_offset_{};
  Eigen::Matrix3d rest_pelvis_frame_ = Eigen::Matrix3d::Identity();  // the driver's, at rest
  double driver_trunk_ = 1;         // the driver's pelvis to neck, standing at rest
  double pelvis_height_ratio_ = 1;  // subject's standing pelvis height / the driver's
  SubjectJoints rest_;
};

}  // namespace mocap
