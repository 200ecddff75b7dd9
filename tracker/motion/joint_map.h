// Joint maps: which joint of a BVH skeleton sits on which point of the body model. The two namings
// of the CMU motion capture people download (bvh11 and cgspeed) are built in and recognised from
// the skeleton's joint names; any other skeleton (an animation tool's export, another lab's
// marker set) is mapped by a small YAML file (an example: tracker/models/joint_maps/).
#pragma once

#include <string>
#include <vector>

namespace mocap {

struct BvhSkeleton;

// One model point and the BVH joint it sits on. An End Site is named after its joint, as the BVH
// reader names it: "Head_End" is the End Site of Head.
struct JointCorrespondence {
  std::string model_point;
  std::string bvh_joint;
  int line = 0;  // the entry's line in the map file, 0 for a built-in map
};

struct JointMap {
  std::string name;    // "bvh11", "cgspeed", or the map file's `name`
  std::string source;  // the map file, for error messages; empty for a built-in map
  std::vector<JointCorrespondence> joints;

  // "<source>:<line>: " for an entry of a map file, "joint map '<name>': " for a built-in one.
  std::string where(const JointCorrespondence& entry) const;
};

// The CMU 31-joint skeleton as converted by B. Hahne, in its two distributed namings. "neck" is
// the base of the upper neck (bvh11 Neck, cgspeed Neck1), not the lower neck: that one sits at
// the top of the thorax, about 8 cm below the shoulder line, which the model's rigid chest cannot
// match, whereas the upper neck sits at the shoulders' height as the model's neck does.
extern const JointMap kBvh11JointMap;    // metres; LeftHip, LeftKnee, ..., LeftShoulder = upper arm
extern const JointMap kCgspeedJointMap;  // LeftUpLeg, LeftLeg, ..., LeftArm = upper arm

// The built-in maps, tried in this order by recogniseJointMap.
const std::vector<const JointMap*>& builtinJointMaps();

// The first built-in map whose joints the skeleton all has. Throws std::runtime_error naming,
// for every built-in naming, the joints the skeleton lacks, and saying a joint map file is needed.
const JointMap& recogniseJointMap(const BvhSkeleton& skeleton);

// Joint map files (YAML):
//
//   name: my_tool          # optional; names the map in messages
//   joints:                # model point: BVH joint (an End Site: "<joint>_End")
//     pelvis: hip
//     head_top: head_End
//     l_knee: lShin
//     ...
//
// Every model point needs an entry; that is checked against the model and the skeleton when the
// map is used (checkJointMap), with the entry's file and line. The parser throws
// std::runtime_error "<source>:<line>: <reason>" for text that is not YAML, a document that is not
// a map with `joints`, unknown top-level keys, a joint that is not a non-empty name, and a model
// point listed twice.
JointMap parseJointMap(const std::string& yaml_text, const std::string& source);
JointMap loadJointMap(const std::string& path);

// Checks `map` against the skeleton and, when `model_points` is not empty, the model's point
// names: throws std::runtime_error "<source>:<line>: ..." for an entry naming a joint the skeleton
// lacks or a point the model lacks, and "<source>: ..." naming every model point without an entry.
void checkJointMap(const JointMap& map, const BvhSkeleton& skeleton,
                   const std::vector<std::string>& model_points = {});

}  // namespace mocap
