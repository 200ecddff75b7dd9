// BVH reading: the shared CMU files, forward kinematics against hand-computed positions in two
// rotation orders, and malformed files rejected with file:line messages.
#include "tests/shared_data.h"
#include "tracker/motion/bvh.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

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

}  // namespace
}  // namespace mocap
