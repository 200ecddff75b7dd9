// BVH reading: the shared CMU files, forward kinematics against hand-computed positions in two
// rotation orders, and malformed files rejected with file:line messages.
#include "tracker/motion/bvh.h"
#include "tests/shared_data.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace mocap {
namespace {

using ::testing::HasSubstr;

const std::string kMotionDir = testing_support::kSharedMotionDir;

// Hips (ZYX) with one child joint (ZXY) and an End Site; one frame.
constexpr const char* kSmall = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Arm
  {
    OFFSET 1 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 1 0
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.04
1 2 3 90 90 0 90 90 0
)";

TEST(Bvh, ParsesASmallHierarchy) {
  const Bvh bvh = parseBvh(kSmall, "small.bvh");
  ASSERT_EQ(bvh.skeleton.joints.size(), 3u);
  EXPECT_EQ(bvh.skeleton.channel_count, 9);
  const BvhJoint& arm = bvh.skeleton.joints[1];
  EXPECT_EQ(arm.name, "Arm");
  EXPECT_EQ(arm.parent, 0);
  EXPECT_EQ(arm.first_channel, 6);
  EXPECT_EQ(arm.channels, (std::vector<BvhChannel>{BvhChannel::kZrotation, BvhChannel::kXrotation,
                                                   BvhChannel::kYrotation}));
  EXPECT_TRUE(bvh.skeleton.joints[2].is_end_site);
  EXPECT_EQ(bvh.skeleton.joints[2].name, "Arm_End");
  EXPECT_EQ(bvh.skeleton.endSiteOf(1), 2);
  EXPECT_EQ(bvh.skeleton.endSiteOf(0), -1);
  ASSERT_EQ(bvh.motion.frames.size(), 1u);
  EXPECT_DOUBLE_EQ(bvh.motion.frame_time, 0.04);
}

TEST(Bvh, ForwardKinematicsComposesChannelsInFileOrder) {
  const Bvh bvh = parseBvh(kSmall, "small.bvh");
  const std::vector<Eigen::Vector3d> p = bvhJointPositions(bvh.skeleton, bvh.motion.frames[0]);
  // Hips: at (1, 2, 3), R = Rz(90) Ry(90). Arm = hips + R (1,0,0) = hips + (0,0,-1).
  EXPECT_TRUE(p[0].isApprox(Eigen::Vector3d(1, 2, 3), 1e-12));
  EXPECT_NEAR((p[1] - Eigen::Vector3d(1, 2, 2)).norm(), 0, 1e-12);
  // Arm: R_arm = Rz(90) Rx(90) takes (0,1,0) to (0,0,1); the hips take that to (0,1,0).
  EXPECT_NEAR((p[2] - Eigen::Vector3d(1, 3, 2)).norm(), 0, 1e-12);
  // Rest pose: the offsets alone.
  const std::vector<Eigen::Vector3d> rest = bvhRestPositions(bvh.skeleton);
  EXPECT_NEAR((rest[2] - Eigen::Vector3d(1, 1, 0)).norm(), 0, 1e-12);
}

TEST(Bvh, ReadsTheSharedCmuFiles) {
  REQUIRE_SHARED_FILE(kMotionDir + "cmu_131_01_walk.bvh");
  const Bvh walk = loadBvh(kMotionDir + "cmu_131_01_walk.bvh");
  const Bvh hop = loadBvh(kMotionDir + "cmu_131_03_hop.bvh");
  for (const Bvh* bvh : {&walk, &hop}) {
    const BvhSkeleton& s = bvh->skeleton;
    int end_sites = 0;
    for (const BvhJoint& j : s.joints) end_sites += j.is_end_site;
    EXPECT_EQ(s.joints.size() - end_sites, 31u);  // CMU's 31 joints
    EXPECT_EQ(end_sites, 7);                      // feet, head, fingers, thumbs
    EXPECT_EQ(s.channel_count, 6 + 30 * 3);
    EXPECT_EQ(s.joints[0].name, "Hips");
    EXPECT_EQ(s.joints[0].channels,
              (std::vector<BvhChannel>{BvhChannel::kXposition, BvhChannel::kYposition,
                                       BvhChannel::kZposition, BvhChannel::kZrotation,
                                       BvhChannel::kYrotation, BvhChannel::kXrotation}));
    const std::vector<BvhChannel> zyx = {BvhChannel::kZrotation, BvhChannel::kYrotation,
                                         BvhChannel::kXrotation};
    const std::vector<BvhChannel> zxy = {BvhChannel::kZrotation, BvhChannel::kXrotation,
                                         BvhChannel::kYrotation};
    EXPECT_EQ(s.joints[s.jointIndex("LeftKnee")].channels, zyx);
    EXPECT_EQ(s.joints[s.jointIndex("LeftElbow")].channels, zxy);
    EXPECT_EQ(s.joints[s.jointIndex("RightShoulder")].channels, zxy);
    EXPECT_GE(s.endSiteOf(s.jointIndex("Head")), 0);
    EXPECT_NEAR(bvh->motion.frame_time, 1.0 / 120, 1e-6);
    // Metres, Y up: the subject's hips about a metre above the floor.
    const std::vector<Eigen::Vector3d> p = bvhJointPositions(s, bvh->motion.frames[0]);
    EXPECT_NEAR(p[0].y(), 0.95, 0.1);
    EXPECT_GT(p[s.endSiteOf(s.jointIndex("Head"))].y(), 1.3);
    EXPECT_LT(p[s.jointIndex("LeftToe")].y(), 0.15);
  }
  EXPECT_EQ(walk.motion.frames.size(), 995u);
  EXPECT_EQ(hop.motion.frames.size(), 1248u);
}

std::string errorOf(const std::string& text) {
  try {
    parseBvh(text, "bad.bvh");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  text.replace(text.find(from), from.size(), to);
  return text;
}

TEST(Bvh, MalformedFilesNameFileAndLine) {
  EXPECT_THAT(errorOf(replaced(kSmall, "  JOINT Arm\n  {", "  JOINT Arm\n")),
              HasSubstr("bad.bvh:8: expected '{' opening joint 'Arm', got 'OFFSET'"));
  EXPECT_THAT(errorOf(replaced(kSmall, "    }\n  }\n}", "    }\n  }")),
              HasSubstr("bad.bvh:14: missing '}' closing joint 'Hips' (opened at line 2)"));
  EXPECT_THAT(errorOf(replaced(kSmall, "OFFSET 1 0 0", "OFSET 1 0 0")),
              HasSubstr("bad.bvh:8: unknown keyword 'OFSET' in joint 'Arm'"));
  EXPECT_THAT(errorOf(replaced(kSmall, "OFFSET 1 0 0", "OFFSET 1 zero 0")),
              HasSubstr("bad.bvh:8: joint 'Arm' OFFSET: not a number: 'zero'"));
  EXPECT_THAT(
      errorOf(replaced(kSmall, "Zrotation Xrotation Yrotation", "Zrotation Xrotation Wrotation")),
      HasSubstr("bad.bvh:9: joint 'Arm': unknown channel 'Wrotation'"));
  EXPECT_THAT(errorOf(replaced(kSmall, "CHANNELS 3 Z", "CHANNELS 2 Z")),
              HasSubstr("bad.bvh:9: unknown keyword 'Yrotation'"));
  EXPECT_THAT(errorOf(replaced(kSmall, "90 90 0 90 90 0\n", "90 90 0 90 90\n")),
              HasSubstr("bad.bvh:19: frame 0 has 8 values, the hierarchy has 9 channels"));
  EXPECT_THAT(errorOf(replaced(kSmall, "1 2 3 90", "1 2 x 90")),
              HasSubstr("bad.bvh:19: frame 0, value 3: not a number: 'x'"));
  EXPECT_THAT(errorOf(replaced(kSmall, "Frames: 1\n", "")),
              HasSubstr("bad.bvh:17: expected 'Frames: <value>', got 'Frame Time: 0.04'"));
  EXPECT_THAT(errorOf(replaced(kSmall, "Frame Time: 0.04\n", "")),
              HasSubstr("bad.bvh:18: expected 'Frame Time: <value>'"));
  EXPECT_THAT(errorOf(replaced(kSmall, "Frames: 1", "Frames: 2")),
              HasSubstr("bad.bvh:19: 'Frames: 2' (line 17) but the file has 1 frame lines"));
  EXPECT_THAT(errorOf(std::string(kSmall) + "1 2 3 0 0 0 0 0 0\n"),
              HasSubstr("bad.bvh:20: more frame lines than the 1 declared by 'Frames:' (line 17)"));
  EXPECT_THAT(errorOf(replaced(kSmall, "Frame Time: 0.04", "Frame Time: 0")),
              HasSubstr("bad.bvh:18: Frame Time: must be positive"));
  EXPECT_THAT(errorOf(replaced(kSmall, "MOTION", "MOTON")),
              HasSubstr("missing the MOTION section"));
  EXPECT_THAT(errorOf(replaced(kSmall, "HIERARCHY", "HIERARCHIE")),
              HasSubstr("bad.bvh:1: expected 'HIERARCHY'"));
  EXPECT_THAT(errorOf(replaced(kSmall, "End Site", "End Sight")),
              HasSubstr("bad.bvh:10: expected 'Site' after 'End', got 'Sight'"));
  EXPECT_THROW(loadBvh("/nonexistent/walk.bvh"), std::runtime_error);
}

// The common CMU release's form (cgspeed naming, CMU units, a reference pose first) beside bvh11's.
const char* const kBvh11Files[] = {"cmu_131_01_walk.bvh", "cmu_131_03_hop.bvh"};
const char* const kCgspeedFiles[] = {"cmu_104_02_walk.bvh", "cmu_16_20_walk_turn.bvh",
                                     "cmu_111_23_run.bvh"};

Bvh parseFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parseBvh(buffer.str(), path);
}

TEST(BvhImport, DetectsTheUnitsFromTheSkeletonsSize) {
  for (const char* file : kBvh11Files) {
    REQUIRE_SHARED_FILE(kMotionDir + file);
    EXPECT_EQ(detectBvhUnits(parseFile(kMotionDir + file).skeleton), BvhUnits::kMetres) << file;
    EXPECT_EQ(loadBvh(kMotionDir + file).metres_per_unit, 1) << file;
  }
  for (const char* file : kCgspeedFiles) {
    REQUIRE_SHARED_FILE(kMotionDir + file);
    const Bvh raw = parseFile(kMotionDir + file);
    EXPECT_EQ(detectBvhUnits(raw.skeleton), BvhUnits::kCmu) << file;
    EXPECT_NEAR(bvhRestSize(raw.skeleton) * kCmuMetresPerUnit, 1.65, 0.4) << file;  // 1.38-1.8
    const Bvh bvh = loadBvh(kMotionDir + file);
    EXPECT_EQ(bvh.metres_per_unit, kCmuMetresPerUnit);
    // Metres, Y up: the hips about a metre above the floor, the head above 1.3 m, a toe low.
    const BvhSkeleton& s = bvh.skeleton;
    const std::vector<Eigen::Vector3d> p = bvhJointPositions(s, bvh.motion.frames[0]);
    EXPECT_NEAR(p[0].y(), 0.95, 0.15) << file;
    EXPECT_GT(p[s.jointIndex("Head_End")].y(), 1.3) << file;
    EXPECT_LT(std::min(p[s.jointIndex("LeftToeBase")].y(), p[s.jointIndex("RightToeBase")].y()),
              0.15)
        << file;
  }
}

TEST(BvhImport, LeavesAFileInMetresAsRead) {
  REQUIRE_SHARED_FILE(kMotionDir + "cmu_131_01_walk.bvh");
  const Bvh raw = parseFile(kMotionDir + "cmu_131_01_walk.bvh");
  const Bvh loaded = loadBvh(kMotionDir + "cmu_131_01_walk.bvh");
  ASSERT_EQ(loaded.skeleton.joints.size(), raw.skeleton.joints.size());
  for (std::size_t j = 0; j < raw.skeleton.joints.size(); ++j)
    EXPECT_EQ(loaded.skeleton.joints[j].offset, raw.skeleton.joints[j].offset);
  ASSERT_EQ(loaded.motion.frames.size(), raw.motion.frames.size());
  for (std::size_t k = 0; k < raw.motion.frames.size(); ++k)
    ASSERT_EQ(loaded.motion.frames[k], raw.motion.frames[k]) << "frame " << k;
}

TEST(BvhImport, ForcedUnitsOverrideTheDetection) {
  const std::string path = kMotionDir + "cmu_104_02_walk.bvh";
  REQUIRE_SHARED_FILE(path);
  const Bvh raw = parseFile(path);
  const int hip = raw.skeleton.jointIndex("LeftUpLeg");
  const Eigen::Vector3d raw_offset = raw.skeleton.joints[hip].offset;
  BvhLoadOptions options;
  options.units = BvhUnits::kCentimetres;
  Bvh bvh = loadBvh(path, options);
  EXPECT_EQ(bvh.metres_per_unit, 0.01);
  EXPECT_TRUE(bvh.skeleton.joints[hip].offset.isApprox(0.01 * raw_offset));
  EXPECT_NEAR(bvh.motion.frames[0][1], 0.01 * raw.motion.frames[1][1], 1e-12);  // root height
  EXPECT_EQ(bvh.motion.frames[0][4], raw.motion.frames[1][4]);                  // an angle
  // A factor wins over the units.
  options.metres_per_unit = 0.05;
  bvh = loadBvh(path, options);
  EXPECT_EQ(bvh.metres_per_unit, 0.05);
  EXPECT_TRUE(bvh.skeleton.joints[hip].offset.isApprox(0.05 * raw_offset));
  options = {};
  options.units = BvhUnits::kMetres;
  EXPECT_EQ(loadBvh(path, options).skeleton.joints[hip].offset, raw_offset);

  // A skeleton no person's size in any unit must have its units forced.
  const std::string tiny =
      replaced(replaced(kSmall, "OFFSET 1 0 0", "OFFSET 0.01 0 0"), "OFFSET 0 1 0", "OFFSET 0 0 0");
  Bvh small = parseBvh(tiny, "tiny.bvh");
  try {
    prepareBvh(small, {});
    ADD_FAILURE() << "no error for a skeleton 1 cm across";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("tiny.bvh: cannot tell the length unit: the skeleton's rest "
                                    "pose is 0.01 units across"));
    EXPECT_THAT(e.what(), HasSubstr("force the units"));
  }
  options = {};
  options.units = BvhUnits::kMillimetres;
  prepareBvh(small, options);
  EXPECT_NEAR(small.skeleton.joints[1].offset.x(), 1e-5, 1e-18);

  EXPECT_EQ(parseBvhUnits("cmu"), BvhUnits::kCmu);
  EXPECT_EQ(parseBvhUnits("auto"), BvhUnits::kAuto);
  EXPECT_STREQ(bvhUnitsName(BvhUnits::kInches), "inch");
  EXPECT_EQ(metresPerUnit(BvhUnits::kInches), 0.0254);
  try {
    parseBvhUnits("feet");
    ADD_FAILURE() << "no error for 'feet'";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("expected one of auto, m, cm, mm, cmu, inch, got 'feet'"));
  }
}

TEST(BvhImport, DropsTheReferencePoseAtTheStart) {
  for (const char* file : kCgspeedFiles) {
    REQUIRE_SHARED_FILE(kMotionDir + file);
    const Bvh raw = parseFile(kMotionDir + file);
    EXPECT_EQ(referencePoseFrames(raw.skeleton, raw.motion), 1) << file;
    const Bvh bvh = loadBvh(kMotionDir + file);
    EXPECT_EQ(bvh.reference_frames, 1) << file;
    ASSERT_EQ(bvh.motion.frames.size() + 1, raw.motion.frames.size()) << file;
    EXPECT_EQ(bvh.motion.frames[0].tail(90), raw.motion.frames[1].tail(90)) << file;  // angles
  }
  const Bvh walk = loadBvh(kMotionDir + "cmu_104_02_walk.bvh");
  EXPECT_EQ(walk.motion.frames.size(), 885u);  // 886 in the file
  BvhLoadOptions keep;
  keep.skip_reference_pose = false;
  const Bvh kept = loadBvh(kMotionDir + "cmu_104_02_walk.bvh", keep);
  EXPECT_EQ(kept.motion.frames.size(), 886u);
  EXPECT_EQ(kept.reference_frames, 0);

  // The bvh11 files start with motion.
  for (const char* file : kBvh11Files) {
    REQUIRE_SHARED_FILE(kMotionDir + file);
    const Bvh raw = parseFile(kMotionDir + file);
    EXPECT_EQ(referencePoseFrames(raw.skeleton, raw.motion), 0) << file;
    EXPECT_EQ(loadBvh(kMotionDir + file).motion.frames.size(), raw.motion.frames.size()) << file;
  }

  // A subject holding the T-pose is motion: without the jump, nothing is dropped.
  BvhMotion held = kept.motion;
  held.frames.assign(20, kept.motion.frames[0]);
  EXPECT_EQ(referencePoseFrames(kept.skeleton, held), 0);
  held.frames.insert(held.frames.end(), kept.motion.frames.begin() + 1, kept.motion.frames.end());
  EXPECT_EQ(referencePoseFrames(kept.skeleton, held), 20);  // a longer reference, then the jump
  // A root turned by whole turns is still unturned.
  BvhMotion turned = kept.motion;
  turned.frames[0][3] = 360;
  EXPECT_EQ(referencePoseFrames(kept.skeleton, turned), 1);
}

TEST(BvhImport, ReadsWindowsLineEndings) {
  const std::string path = kMotionDir + "cmu_111_23_run.bvh";
  REQUIRE_SHARED_FILE(path);
  std::ifstream in(path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_NE(text.find("\r\n"), std::string::npos) << "the shared copy keeps its CRLF line ends";
  const Bvh bvh = loadBvh(path);
  EXPECT_EQ(bvh.motion.frames.size(), 1129u);  // 1130 frames, the first the reference pose
  EXPECT_EQ(bvh.skeleton.joints[0].name, "Hips");
  EXPECT_NEAR(bvh.motion.frame_time, 1.0 / 120, 1e-6);
}

}  // namespace
}  // namespace mocap
