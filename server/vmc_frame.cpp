// Poses as VMC frames: the segment-to-bone table and the change to Unity's frame and T-pose rest.
#include "server/vmc_frame.h"

#include <cmath>
#include <stdexcept>

#include "tracker/model/kinematics.h"

namespace mocap {
namespace {

// How a segment's T-pose differs from the body's zero pose: not at all, or the arm raised a
// quarter turn sideways (about the forward axis, +Y: the right arm by -90 degrees so that it
// points along +X, the left by +90 degrees).
enum class Raise { kNone, kRightArm, kLeftArm };

struct BoneOfSegment {
  const char* segment;
  const char* bone;
  Raise raise;
};

// tracker/models/human.yaml's segments. The chest's joint is the spine's, so it drives Spine; the
// head's is at the neck's base, but drives Head, which every humanoid has (Neck is optional). The
// forearm carries the hand.
constexpr BoneOfSegment kHumanBones[] = {
    {"pelvis", "Hips", Raise::kNone},
    {"chest", "Spine", Raise::kNone},
    {"head", "Head", Raise::kNone},
    {"r_thigh", "RightUpperLeg", Raise::kNone},
    {"r_shin", "RightLowerLeg", Raise::kNone},
    {"r_foot", "RightFoot", Raise::kNone},
    {"l_thigh", "LeftUpperLeg", Raise::kNone},
    {"l_shin", "LeftLowerLeg", Raise::kNone},
    {"l_foot", "LeftFoot", Raise::kNone},
    {"r_upper_arm", "RightUpperArm", Raise::kRightArm},
    {"r_forearm", "RightLowerArm", Raise::kRightArm},
    {"l_upper_arm", "LeftUpperArm", Raise::kLeftArm},
    {"l_forearm", "LeftLowerArm", Raise::kLeftArm},
};

const BoneOfSegment* boneOf(const std::string& segment) {
  for (const BoneOfSegment& entry : kHumanBones)
    if (segment == entry.segment) return &entry;
  return nullptr;
}

Eigen::Quaterniond tposeRotation(Raise raise) {
  switch (raise) {
    case Raise::kRightArm:
      return Eigen::Quaterniond(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()));
    case Raise::kLeftArm:
      return Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()));
    case Raise::kNone:
      break;
  }
  return Eigen::Quaterniond::Identity();
}

}  // namespace

Eigen::Vector3d toUnity(const Eigen::Vector3d& world) { return {world.x(), world.z(), world.y()}; }

Eigen::Quaterniond toUnity(const Eigen::Quaterniond& world) {
  // M R M^T for the y-z swap M: a mirror, so the axis is mirrored and the angle reversed.
  return Eigen::Quaterniond(world.w(), -world.x(), -world.z(), -world.y());
}

VmcRig makeVmcRig(const BodyModel& body) {
  VmcRig rig;
  if (body.segments.empty() || body.segments[0].name != "pelvis") return rig;
  const std::size_t count = body.segments.size();
  // Per segment: its bone (-1: none), its T-pose orientation and the T-pose position of its joint
  // in the world (a segment without a bone keeps its parent's orientation).
  std::vector<int> bone_of(count, -1);
  std::vector<Eigen::Quaterniond> tpose(count, Eigen::Quaterniond::Identity());
  std::vector<Eigen::Vector3d> joint(count, Eigen::Vector3d::Zero());
  for (std::size_t s = 0; s < count; ++s) {
    const Segment& segment = body.segments[s];
    const BoneOfSegment* entry = boneOf(segment.name);
    const int parent = segment.parent;
    if (parent >= 0) {
      tpose[s] = tpose[parent];
      joint[s] = joint[parent] + tpose[parent] * segment.offset;
    }
    if (!entry) continue;
    tpose[s] = tposeRotation(entry->raise);
    // The nearest ancestor with a bone is the parent bone.
    int ancestor = parent;
    while (ancestor >= 0 && bone_of[ancestor] < 0) ancestor = body.segments[ancestor].parent;
    VmcBone bone;
    bone.name = entry->bone;
    bone.segment = static_cast<int>(s);
    bone.parent = ancestor < 0 ? -1 : bone_of[ancestor];
    bone.tpose = tpose[s];
    if (ancestor >= 0) bone.position = toUnity(joint[s] - joint[ancestor]);
    bone_of[s] = static_cast<int>(rig.bones.size());
    rig.bones.push_back(std::move(bone));
  }
  return rig;
}

VmcFrame vmcFrame(const VmcRig& rig, const BodyModel& body, const Pose& pose, double time_s) {
  VmcFrame frame;
  frame.tracking = true;
  frame.time_s = time_s;
  if (rig.empty()) return frame;
  if (pose.orientations.size() < body.segments.size() ||
      pose.dofs.size() != static_cast<long>(body.dofs.size()))
    throw std::invalid_argument("the pose is not of the VMC rig's body");
  // World rotations from the T-pose, tracker frame, per bone.
  std::vector<Eigen::Quaterniond> world(rig.bones.size());
  frame.bones.reserve(rig.bones.size());
  for (std::size_t b = 0; b < rig.bones.size(); ++b) {
    const VmcBone& bone = rig.bones[b];
    world[b] = (pose.orientations[bone.segment] * bone.tpose.conjugate()).normalized();
    const Eigen::Quaterniond local =
        bone.parent < 0 ? world[b] : world[bone.parent].conjugate() * world[b];
    // The Hips (the body's root) are placed in the world; other bones keep their T-pose offset.
    const Eigen::Vector3d position =
        bone.parent < 0 ? toUnity(localTransform(body, bone.segment, pose.dofs).translation())
                        : bone.position;
    frame.bones.push_back({bone.name, position, toUnity(local)});
  }
  return frame;
}

VmcFrame vmcLostFrame(double time_s) {
  VmcFrame frame;
  frame.time_s = time_s;
  return frame;
}

}  // namespace mocap
