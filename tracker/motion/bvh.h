// BVH motion files (Biovision hierarchy): the skeleton, the per-frame channel values, and forward
// kinematics of the skeleton in the file's own frame and units. Real motion capture (the CMU files
// in data/motion/) enters the tracker through here; degrees exist only in this file format.
// loadBvh also takes a file as people have it to what the tracker expects: lengths in metres
// whatever the file's unit, and the motion without the reference pose some files start with.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tracker/motion/joint_map.h"

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
  std::string source;            // the file, for error messages
  // Which joint is which model point, when a map file was given (BvhLoadOptions::joint_map);
  // null: the naming is recognised from the joint names (recogniseJointMap).
  std::shared_ptr<const JointMap> joint_map;

  int jointIndex(const std::string& joint_name) const;  // -1 if absent
  // The End Site child of joint `j`, or -1 if it has none.
  int endSiteOf(int j) const;
};

struct BvhMotion {
  double frame_time = 0;                // seconds
  std::vector<Eigen::VectorXd> frames;  // channel values, file order (degrees; loadBvh: metres)
};

struct Bvh {
  BvhSkeleton skeleton;
  BvhMotion motion;
  double metres_per_unit = 1;  // what loadBvh multiplied the file's lengths by
  int reference_frames = 0;    // leading reference-pose frames loadBvh dropped
};

// The length unit of a file. CMU's own unit (the common CMU release) is 0.056444 m; inches are
// never guessed (a person in inches measures much as one in CMU units), only forced.
enum class BvhUnits { kAuto, kMetres, kCentimetres, kMillimetres, kCmu, kInches };
inline constexpr double kCmuMetresPerUnit = 0.056444;

// How loadBvh reads a file.
struct BvhLoadOptions {
  // kAuto: the unit that makes the skeleton's rest pose a person's size (detectBvhUnits).
  BvhUnits units = BvhUnits::kAuto;
  // > 0: lengths are multiplied by this factor, whatever `units` says (a unit not listed above).
  double metres_per_unit = 0;
  // Drop the reference pose the file starts with, if it starts with one (referencePoseFrames).
  bool skip_reference_pose = true;
  // A joint map file (YAML, see joint_map.h) for a skeleton whose naming is not built in; empty:
  // recognised from the joint names. Checked against the skeleton on load.
  std::string joint_map;
};

// The BvhUnits named by `text` ("auto", "m", "cm", "mm", "cmu", "inch"), for flags and config
// files. Throws std::invalid_argument listing the names otherwise.
BvhUnits parseBvhUnits(const std::string& text);
const char* bvhUnitsName(BvhUnits units);
double metresPerUnit(BvhUnits units);  // kAuto: throws std::invalid_argument

// The size of the skeleton's rest pose, in file units: the largest extent of the box around its
// joints and End Sites (a person's height, or the arm span of a T-pose).
double bvhRestSize(const BvhSkeleton& skeleton);
// The unit (metres, centimetres, millimetres or CMU units) in which the rest pose is nearest a
// 1.7 m person. Throws std::runtime_error naming the skeleton's size when even that unit makes it
// under 0.5 m or over 3.5 m: the units must then be forced.
BvhUnits detectBvhUnits(const BvhSkeleton& skeleton);

// The number of leading frames that are a reference pose rather than motion, as in the common CMU
// release: the root's rotation zero (modulo 360 degrees), at least three quarters of the other
// rotation channels zero, and then a jump to the motion (the change to the next frame over 5
// times as large as the motion's own frame-to-frame change, and over 2 degrees on average).
// 0 when the file starts with motion, or has too few frames to tell.
int referencePoseFrames(const BvhSkeleton& skeleton, const BvhMotion& motion);

// What loadBvh does after parsing: lengths to metres, the reference pose dropped, the joint map
// read and checked against the skeleton, as `options` say.
void prepareBvh(Bvh& bvh, const BvhLoadOptions& options);

// Parses BVH text. `source` names the file in error messages. Throws std::runtime_error with
// "<source>:<line>: <reason>" for any malformed input: missing braces, unknown keywords, bad
// channel names or counts, non-numeric values, a frame line with the wrong number of values,
// Frames/Frame Time missing or disagreeing with the data.
// The lengths and frames are the file's own; see loadBvh.
Bvh parseBvh(const std::string& text, const std::string& source);
// parseBvh, then prepareBvh: metres, the motion starting past a reference pose.
Bvh loadBvh(const std::string& path, const BvhLoadOptions& options = {});

// World positions of every joint and End Site for one frame of channel values, in the file's
// frame and units. A joint's transform is translate(offset + its position channels) followed by
// its rotation channels composed in file order (the first listed is the outermost), so
// "Zrotation Xrotation Yrotation" means R = Rz * Rx * Ry.
std::vector<Eigen::Vector3d> bvhJointPositions(const BvhSkeleton& skeleton,
                                               const Eigen::VectorXd& frame);

// The positions of the rest pose (every channel at zero): the skeleton's own proportions.
std::vector<Eigen::Vector3d> bvhRestPositions(const BvhSkeleton& skeleton);

}  // namespace mocap
