// Joint maps: the built-in CMU namings, recognising a skeleton's naming, and the YAML map files.
#include "tracker/motion/joint_map.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "tracker/motion/bvh.h"

namespace mocap {

const JointMap kBvh11JointMap = {"bvh11",
                                 "",
                                 {
                                     {"pelvis", "Hips"},        {"neck", "Neck"},
                                     {"head_top", "Head_End"},  {"l_hip", "LeftHip"},
                                     {"l_knee", "LeftKnee"},    {"l_ankle", "LeftAnkle"},
                                     {"l_toe", "LeftToe"},      {"r_hip", "RightHip"},
                                     {"r_knee", "RightKnee"},   {"r_ankle", "RightAnkle"},
                                     {"r_toe", "RightToe"},     {"l_shoulder", "LeftShoulder"},
                                     {"l_elbow", "LeftElbow"},  {"l_wrist", "LeftWrist"},
                                     {"l_hand", "LFingers"},    {"r_shoulder", "RightShoulder"},
                                     {"r_elbow", "RightElbow"}, {"r_wrist", "RightWrist"},
                                     {"r_hand", "RFingers"},
                                 }};

const JointMap kCgspeedJointMap = {"cgspeed",
                                   "",
                                   {
                                       {"pelvis", "Hips"},
                                       {"neck", "Neck1"},
                                       {"head_top", "Head_End"},
                                       {"l_hip", "LeftUpLeg"},
                                       {"l_knee", "LeftLeg"},
                                       {"l_ankle", "LeftFoot"},
                                       {"l_toe", "LeftToeBase"},
                                       {"r_hip", "RightUpLeg"},
                                       {"r_knee", "RightLeg"},
                                       {"r_ankle", "RightFoot"},
                                       {"r_toe", "RightToeBase"},
                                       {"l_shoulder", "LeftArm"},
                                       {"l_elbow", "LeftForeArm"},
                                       {"l_wrist", "LeftHand"},
                                       {"l_hand", "LeftHandIndex1"},
                                       {"r_shoulder", "RightArm"},
                                       {"r_elbow", "RightForeArm"},
                                       {"r_wrist", "RightHand"},
                                       {"r_hand", "RightHandIndex1"},
                                   }};

std::string JointMap::where(const JointCorrespondence& entry) const {
  if (source.empty()) return "joint map '" + name + "': ";
  return source + ":" + std::to_string(entry.line) + ": ";
}

const std::vector<const JointMap*>& builtinJointMaps() {
  static const std::vector<const JointMap*> kMaps = {&kBvh11JointMap, &kCgspeedJointMap};
  return kMaps;
}

namespace {

std::string joinNames(const std::vector<std::string>& names) {
  std::string list;
  for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
  return list;
}

std::vector<std::string> missingJoints(const JointMap& map, const BvhSkeleton& skeleton) {
  std::vector<std::string> missing;
  for (const JointCorrespondence& c : map.joints)
    if (skeleton.jointIndex(c.bvh_joint) < 0) missing.push_back(c.bvh_joint);
  return missing;
}

std::string skeletonName(const BvhSkeleton& skeleton) {
  return skeleton.source.empty() ? "BVH skeleton" : skeleton.source;
}

}  // namespace

const JointMap& recogniseJointMap(const BvhSkeleton& skeleton) {
  std::string lacks;
  for (const JointMap* map : builtinJointMaps()) {
    const std::vector<std::string> missing = missingJoints(*map, skeleton);
    if (missing.empty()) return *map;
    lacks += "; as " + map->name + " it lacks " + joinNames(missing);
  }
  throw std::runtime_error(skeletonName(skeleton) +
                           ": the skeleton's joint names are none of the known namings" + lacks +
                           ". Give a joint map file (YAML) saying which joint is which");
}

JointMap parseJointMap(const std::string& yaml_text, const std::string& source) {
  auto fail = [&](const YAML::Node& node, const std::string& reason) {
    const int line = node.IsDefined() && node.Mark().line >= 0 ? node.Mark().line + 1 : 1;
    throw std::runtime_error(source + ":" + std::to_string(line) + ": " + reason);
  };
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(source + ":" + std::to_string(e.mark.line + 1) +
                             ": not valid YAML: " + e.msg);
  }
  if (!root.IsMap()) fail(root, "expected a map with 'joints' (model point: BVH joint)");
  for (const auto& entry : root) {
    const std::string& key = entry.first.Scalar();
    if (key != "name" && key != "joints")
      fail(entry.first, "unknown key '" + key + "' (known: name, joints)");
  }
  JointMap map;
  map.source = source;
  map.name = source;
  if (const YAML::Node name = root["name"]) {
    if (!name.IsScalar() || name.Scalar().empty()) fail(name, "name: expected a non-empty string");
    map.name = name.Scalar();
  }
  const YAML::Node joints = root["joints"];
  if (!joints) fail(root, "missing 'joints' (model point: BVH joint)");
  if (!joints.IsMap() || joints.size() == 0)
    fail(joints, "joints: expected a map of model point: BVH joint");
  for (const auto& entry : joints) {
    const std::string& point = entry.first.Scalar();
    if (!entry.second.IsScalar() || entry.second.Scalar().empty())
      fail(entry.second, "joints." + point + ": expected the name of a BVH joint");
    for (const JointCorrespondence& c : map.joints)
      if (c.model_point == point)
        fail(entry.first,
             "joints." + point + ": listed twice (first at line " + std::to_string(c.line) + ")");
    map.joints.push_back({point, entry.second.Scalar(), entry.first.Mark().line + 1});
  }
  return map;
}

JointMap loadJointMap(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open joint map file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parseJointMap(buffer.str(), path);
}

void checkJointMap(const JointMap& map, const BvhSkeleton& skeleton,
                   const std::vector<std::string>& model_points) {
  for (const JointCorrespondence& c : map.joints) {
    if (!model_points.empty() &&
        std::find(model_points.begin(), model_points.end(), c.model_point) == model_points.end())
      throw std::runtime_error(
          map.where(c) + "'" + c.model_point +
          "' is not a point of the body model (its points: " + joinNames(model_points) + ")");
    if (skeleton.jointIndex(c.bvh_joint) < 0)
      throw std::runtime_error(map.where(c) + "'" + c.bvh_joint + "' (for '" + c.model_point +
                               "') is not a joint of " + skeletonName(skeleton) +
                               " (an End Site is '<joint>_End')");
  }
  std::vector<std::string> unmapped;
  for (const std::string& point : model_points) {
    const bool mapped =
        std::any_of(map.joints.begin(), map.joints.end(),
                    [&](const JointCorrespondence& c) { return c.model_point == point; });
    if (!mapped) unmapped.push_back(point);
  }
  if (!unmapped.empty())
    throw std::runtime_error((map.source.empty() ? "joint map '" + map.name + "'" : map.source) +
                             ": no BVH joint for the model's " + joinNames(unmapped));
}

}  // namespace mocap
