// BVH motion files (Biovision hierarchy): the skeleton, the per-frame channel values, and forward
// kinematics of the skeleton in the file's own frame and units. Real motion capture (the CMU files
// in data/motion/) enters the tracker through here; degrees exist only in this file format.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace mocap {

enum class BvhChannel { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };

struct BvhJoint {
  std::string name;  // End Sites are named after their parent: "<parent>_End"
  int parent = -1;   // -1 for the root
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // from the parent's origin, parent's frame
  std::vector<BvhChannel> channels;                  // in file order
  int first_channel = 0;                             // index of channels[0] in a frame's values
  bool is_end_site = false;
};

struct BvhSkeleton {
  std::vector<BvhJoint> joints;  // depth-first file order: parents precede their children
  int channel_count = 0;         // values per frame

  int jointIndex(const std::string& joint_name) const;  // -1 if absent
  // The End Site child of joint `j`, or -1 if it has none.
  int endSiteOf(int j) const;
};

struct BvhMotion {
  double frame_time = 0;                // seconds
  std::vector<Eigen::VectorXd> frames;  // channel values in file order (degrees, file units)
};

struct Bvh {
  BvhSkeleton skeleton;
  BvhMotion motion;
};

// Parses BVH text. `source` names the file in error messages. Throws std::runtime_error with
// "<source>:<line>: <reason>" for any malformed input: missing braces, unknown keywords, bad
// channel names or counts, non-numeric values, a frame line with the wrong number of values,
// Frames/Frame Time missing or disagreeing with the data.
Bvh parseBvh(const std::string& text, const std::string& source);
Bvh loadBvh(const std::string& path);

// World positions of every joint and End Site for one frame of channel values, in the file's
// frame and units. A joint's transform is translate(offset + its position channels) followed by
// its rotation channels composed in file order (the first listed is the outermost), so
// "Zrotation Xrotation Yrotation" means R = Rz * Rx * Ry.
std::vector<Eigen::Vector3d> bvhJointPositions(const BvhSkeleton& skeleton,
                                               const Eigen::VectorXd& frame);

// The positions of the rest pose (every channel at zero): the skeleton's own proportions.
std::vector<Eigen::Vector3d> bvhRestPositions(const BvhSkeleton& skeleton);

}  // namespace mocap
