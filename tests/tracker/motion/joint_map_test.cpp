// Joint maps: both CMU namings recognised on the shared files, the example map file, a skeleton of
// unknown naming mapped by a YAML file, and the map files' errors (file, line, what is wrong).
#include "tracker/motion/joint_map.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "tests/shared_data.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/retarget.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;

const std::string kMotionDir = testing_support::kSharedMotionDir;

BodyModel humanModel() {
  return loadBodyModel(std::string(MOCAP_SOURCE_DIR) + "/tracker/models/human.yaml");
}

std::vector<std::string> pointNames(const BodyModel& model) {
  std::vector<std::string> names;
  for (const BodyPoint& p : model.points) names.push_back(p.name);
  return names;
}

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

std::string replacedAll(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(JointMap, RecognisesBothCmuNamings) {
  for (const char* file : {"cmu_131_01_walk.bvh", "cmu_131_03_hop.bvh"}) {
    REQUIRE_SHARED_FILE(kMotionDir + file);
    EXPECT_EQ(&recogniseJointMap(loadBvh(kMotionDir + file).skeleton), &kBvh11JointMap) << file;
  }
  for (const char* file :
       {"cmu_104_02_walk.bvh", "cmu_16_20_walk_turn.bvh", "cmu_111_23_run.bvh"}) {
    REQUIRE_SHARED_FILE(kMotionDir + file);
    EXPECT_EQ(&recogniseJointMap(loadBvh(kMotionDir + file).skeleton), &kCgspeedJointMap) << file;
  }
}

// The cgspeed joints chosen for the model's neck and shoulders are where the model has them: the
// neck (Neck1, not the lower Neck) at the shoulders' height, the shoulders at the upper arms'
// start (LeftArm, not the collar LeftShoulder), the hand past the wrist.
TEST(JointMap, CgspeedJointsSitWhereTheModelsPointsDo) {
  REQUIRE_SHARED_FILE(kMotionDir + "cmu_104_02_walk.bvh");
  const Bvh bvh = loadBvh(kMotionDir + "cmu_104_02_walk.bvh");
  const BvhSkeleton& s = bvh.skeleton;
  const std::vector<Eigen::Vector3d> rest = bvhRestPositions(s);
  auto at = [&](const char* joint) { return rest[s.jointIndex(joint)]; };
  EXPECT_NEAR(at("Neck1").y(), at("LeftArm").y(), 0.05);
  EXPECT_GT(at("LeftArm").y() - at("Neck").y(), 0.05);
  EXPECT_GT(at("LeftArm").x() - at("LeftShoulder").x(), 0.1);  // the collar bone's length
  EXPECT_NEAR(at("LeftHandIndex1").x() - at("LeftHand").x(), 0.037, 0.01);  // as bvh11 LFingers
  // Both namings give a CMU subject's proportions: each bone within 25 % of subject 131's.
  REQUIRE_SHARED_FILE(kMotionDir + "cmu_131_01_walk.bvh");
  const BodyModel model = humanModel();
  const std::vector<BoneLength> cgspeed = subjectBoneLengths(model, s);
  const std::vector<BoneLength> bvh11 =
      subjectBoneLengths(model, loadBvh(kMotionDir + "cmu_131_01_walk.bvh").skeleton);
  for (std::size_t b = 0; b < cgspeed.size(); ++b)
    EXPECT_NEAR(cgspeed[b].length / bvh11[b].length, 1, 0.25) << cgspeed[b].name;
}

TEST(JointMap, TheExampleMapFileIsTheCgspeedNaming) {
  const JointMap map =
      loadJointMap(std::string(MOCAP_SOURCE_DIR) + "/tracker/models/joint_maps/cgspeed.yaml");
  EXPECT_EQ(map.name, "cgspeed");
  ASSERT_EQ(map.joints.size(), kCgspeedJointMap.joints.size());
  for (std::size_t k = 0; k < map.joints.size(); ++k) {
    EXPECT_EQ(map.joints[k].model_point, kCgspeedJointMap.joints[k].model_point);
    EXPECT_EQ(map.joints[k].bvh_joint, kCgspeedJointMap.joints[k].bvh_joint);
    EXPECT_GT(map.joints[k].line, 0);
  }
  checkJointMap(map, loadBvh(kMotionDir + "cmu_16_20_walk_turn.bvh").skeleton,
                pointNames(humanModel()));
}

// An exporter's naming: the cgspeed file with every Left/Right renamed. Unknown by itself, mapped
// onto the same joints by a map file.
TEST(JointMap, MapsASkeletonOfAnotherNamingByAMapFile) {
  REQUIRE_SHARED_FILE(kMotionDir + "cmu_104_02_walk.bvh");
  const BodyModel model = humanModel();
  const std::string text = readText(kMotionDir + "cmu_104_02_walk.bvh");
  const std::string renamed_text = replacedAll(replacedAll(text, "Left", "l_"), "Right", "r_");
  const std::string renamed = writeTemp("renamed.bvh", renamed_text);
  const std::string unmapped =
      errorOf([&] { correspondingBvhJoints(model, loadBvh(renamed).skeleton); });
  EXPECT_THAT(unmapped, HasSubstr("renamed.bvh: the skeleton's joint names are none of the known"));
  EXPECT_THAT(unmapped, HasSubstr("as bvh11 it lacks LeftHip, LeftKnee, LeftAnkle"));
  EXPECT_THAT(unmapped, HasSubstr("as cgspeed it lacks LeftUpLeg, LeftLeg, LeftFoot"));
  EXPECT_THAT(unmapped, HasSubstr("Give a joint map file"));

  const std::string map_text = replacedAll(
      replacedAll(
          readText(std::string(MOCAP_SOURCE_DIR) + "/tracker/models/joint_maps/cgspeed.yaml"),
          ": Left", ": l_"),
      ": Right", ": r_");
  BvhLoadOptions options;
  options.joint_map = writeTemp("renamed.yaml", map_text);
  const Bvh mapped = loadBvh(renamed, options);
  ASSERT_TRUE(mapped.skeleton.joint_map);
  EXPECT_EQ(correspondingBvhJoints(model, mapped.skeleton),
            correspondingBvhJoints(model, loadBvh(kMotionDir + "cmu_104_02_walk.bvh").skeleton));
}

TEST(JointMap, MapFileErrorsNameTheFileLineAndWhatIsWrong) {
  auto parsed = [](const std::string& yaml) {
    return errorOf([&] { parseJointMap(yaml, "map.yaml"); });
  };
  EXPECT_THAT(parsed("joints:\n  pelvis: [Hips\n"), HasSubstr("map.yaml:3: not valid YAML"));
  EXPECT_THAT(parsed("- pelvis\n"), HasSubstr("map.yaml:1: expected a map with 'joints'"));
  EXPECT_THAT(parsed("name: x\n"), HasSubstr("map.yaml:1: missing 'joints'"));
  EXPECT_THAT(parsed("name: x\njoint:\n  pelvis: Hips\n"),
              HasSubstr("map.yaml:2: unknown key 'joint' (known: name, joints)"));
  EXPECT_THAT(parsed("joints:\n  pelvis: Hips\n  neck: [Neck1]\n"),
              HasSubstr("map.yaml:3: joints.neck: expected the name of a BVH joint"));
  EXPECT_THAT(parsed("joints:\n  pelvis: Hips\n  neck: Neck1\n  pelvis: Hips\n"),
              HasSubstr("map.yaml:4: joints.pelvis: listed twice (first at line 2)"));

  // Checked against the model and the skeleton where it is used.
  REQUIRE_SHARED_FILE(kMotionDir + "cmu_16_20_walk_turn.bvh");
  const Bvh bvh = loadBvh(kMotionDir + "cmu_16_20_walk_turn.bvh");
  const std::vector<std::string> points = pointNames(humanModel());
  auto checked = [&](const std::string& yaml) {
    return errorOf([&] { checkJointMap(parseJointMap(yaml, "map.yaml"), bvh.skeleton, points); });
  };
  EXPECT_THAT(checked("joints:\n  pelvis: Hips\n  l_kne: LeftLeg\n"),
              HasSubstr("map.yaml:3: 'l_kne' is not a point of the body model (its points: "
                        "pelvis, neck, head_top"));
  EXPECT_THAT(checked("joints:\n  pelvis: Hips\n  l_knee: LeftKnee\n"),
              HasSubstr("map.yaml:3: 'LeftKnee' (for 'l_knee') is not a joint of " + kMotionDir +
                        "cmu_16_20_walk_turn.bvh"));
  std::string without_toes =
      readText(std::string(MOCAP_SOURCE_DIR) + "/tracker/models/joint_maps/cgspeed.yaml");
  without_toes = replacedAll(replacedAll(without_toes, "  l_toe: LeftToeBase\n", ""),
                             "  r_toe: RightToeBase\n", "");
  EXPECT_THAT(checked(without_toes),
              HasSubstr("map.yaml: no BVH joint for the model's r_toe, l_toe"));

  // Through loadBvh, the joints are checked on load.
  BvhLoadOptions options;
  options.joint_map = writeTemp("typo.yaml", "joints:\n  pelvis: Hips\n  neck: Neck2\n");
  EXPECT_THAT(errorOf([&] { loadBvh(kMotionDir + "cmu_16_20_walk_turn.bvh", options); }),
              HasSubstr("typo.yaml:3: 'Neck2' (for 'neck') is not a joint of"));
  options.joint_map = ::testing::TempDir() + "absent.yaml";
  EXPECT_THAT(errorOf([&] { loadBvh(kMotionDir + "cmu_16_20_walk_turn.bvh", options); }),
              HasSubstr("absent.yaml: cannot open joint map file"));
}

}  // namespace
}  // namespace mocap
