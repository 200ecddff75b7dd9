// A tracked pose as a VMC frame (the Virtual Motion Capture protocol, protocol.vmc.info, that
// avatar apps receive): which Unity HumanBodyBones the body's segments drive, and each bone's local
// rotation and position in Unity's frame. Pure, no sockets: server/vmc_sender.h encodes and sends
// the frames.
//
// Conventions, the ones a normalized humanoid (VRM) receiver applies:
// - Axes. The tracker's world is right-handed, Z up, metres; a person at zero yaw faces +Y, their
//   right along +X (tracker/models/human.yaml). Unity's is left-handed, Y up, +Z forward, +X
//   right. A point (x, y, z) is sent as (x, z, y): mocapctl's BVH export turns the world Y up by
//   (x, z, -y), a rotation, and Unity's left-handed frame is that one with z mirrored. The body's
//   forward thus becomes Unity's +Z, a humanoid's own forward. A rotation R is sent as M R M^T
//   (M that swap of y and z), which for a quaternion is (x, y, z, w) -> (-x, -z, -y, w).
// - Rest. Every bone's local rotation is the identity in the T-pose, where every bone's frame is
//   parallel to the root's. The body's zero pose is the T-pose but for the arms, which hang: its
//   T-pose raises each upper arm a quarter turn sideways about the forward axis (the human's
//   shoulder abduction at 90 degrees), forearms straight.
// - Rotations. A bone's world rotation is its segment's world orientation times the inverse of the
//   segment's T-pose orientation: what turns the T-pose bone into the tracked one. It is sent
//   local: the parent bone's world rotation, inverted, times its own. Bones the body has no joint
//   for (Chest, UpperChest, Neck, shoulders, hands, toes, fingers) are not sent: a receiver keeps
//   them at rest, so the rotations sent compose as in the tracked body.
// - Positions. The root ("root") stays at the origin, unrotated, and the Hips carry the pelvis's
//   world position. Any other bone carries its segment's offset from its parent bone's segment in
//   the T-pose: the tracked body's proportions, which a receiver that applies bone positions to an
//   avatar of other proportions (EVMC4U's BonePositionSynchronize) would stretch it to.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "server/pose.h"
#include "tracker/model/body_model.h"

namespace mocap {

// A bone the body drives.
struct VmcBone {
  std::string name;  // Unity's HumanBodyBones name
  int segment = -1;  // the body segment that drives it
  int parent = -1;   // the parent bone, an index into VmcRig::bones; -1: the root
  Eigen::Quaterniond tpose = Eigen::Quaterniond::Identity();  // segment's T-pose, world frame
  Eigen::Vector3d position = Eigen::Vector3d::Zero();         // local, Unity frame (not the Hips')
};

// The bones of one body, parents first. The first is the Hips, driven by the body's root.
struct VmcRig {
  std::vector<VmcBone> bones;
  bool empty() const { return bones.empty(); }
};

// The bones the segments of `body` drive, by the segment names of tracker/models/human.yaml (a
// fitted human keeps them). Empty for a body whose root is not a `pelvis` (the hand).
VmcRig makeVmcRig(const BodyModel& body);

struct VmcBonePose {
  std::string name;
  Eigen::Vector3d position;     // local, Unity frame, metres
  Eigen::Quaterniond rotation;  // local, Unity frame
};

// One bundle's content.
struct VmcFrame {
  bool tracking = false;  // /VMC/Ext/OK: 1 with a pose, 0 while the subject is lost
  double time_s = 0;      // /VMC/Ext/T
  // /VMC/Ext/Root/Pos "root": the origin, unrotated.
  Eigen::Vector3d root_position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond root_rotation = Eigen::Quaterniond::Identity();
  std::vector<VmcBonePose> bones;  // /VMC/Ext/Bone/Pos, parents first; none while lost
};

// The frame of `pose`, a pose of the body `rig` was made from (its orientations and DOFs).
// Throws std::invalid_argument if the pose has fewer segments or DOFs than the rig needs.
VmcFrame vmcFrame(const VmcRig& rig, const BodyModel& body, const Pose& pose, double time_s);
// The frame sent while no pose comes: not tracking, no bones.
VmcFrame vmcLostFrame(double time_s);

// The tracker's world frame to Unity's: a position, and a rotation (see the conventions above).
Eigen::Vector3d toUnity(const Eigen::Vector3d& world);
Eigen::Quaterniond toUnity(const Eigen::Quaterniond& world);

}  // namespace mocap
