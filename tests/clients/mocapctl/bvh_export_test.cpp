// BVH export: the written file parses back with the tracker's own BVH reader and puts every joint
// where the daemon's kinematics does, turned to Y up (or kept Z up), in metres or centimetres; a
// standing body stands along +Y on y = 0, and the root travels as the poses' root does.
#include "clients/mocapctl/bvh_export.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "clients/mocapctl/session_bvh.h"
#include "tracker/model/builtin_models.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/bvh.h"

namespace {

namespace fs = std::filesystem;

// The daemon's Z-up world point as the Y-up file holds it.
Eigen::Vector3d yUp(const Eigen::Vector3d& world) { return {world.x(), world.z(), -world.y()}; }

class BvhExportTest : public testing::Test {
 protected:
  const mocap::BodyModel body_ = mocap::builtinHumanModel();
  const mocap::v1::Skeleton skeleton_ = mocapctl::skeletonOf(body_);

  // Standing with the arms down, turned `yaw` radians and moved to (x, y) on the floor.
  Eigen::VectorXd standing(double x, double y, double yaw) const {
    Eigen::VectorXd q = body_.neutralPose();
    q[body_.dofIndex("root_tx")] = x;
    q[body_.dofIndex("root_ty")] = y;
    q[body_.dofIndex("root_yaw")] = yaw;
    return q;
  }
  // A pose anywhere in the DOFs' limits, the root within a few metres of the origin.
  Eigen::VectorXd randomPose(int seed) const {
    std::srand(static_cast<unsigned>(seed));
    Eigen::VectorXd q(static_cast<Eigen::Index>(body_.dofs.size()));
    for (std::size_t d = 0; d < body_.dofs.size(); ++d) {
      const double lo = std::max(body_.dofs[d].min, -3.0), hi = std::min(body_.dofs[d].max, 3.0);
      q[static_cast<Eigen::Index>(d)] = lo + (hi - lo) * std::rand() / RAND_MAX;
    }
    return q;
  }
  static std::vector<std::vector<double>> frames(const std::vector<Eigen::VectorXd>& poses) {
    std::vector<std::vector<double>> out;
    for (const Eigen::VectorXd& q : poses) out.emplace_back(q.data(), q.data() + q.size());
    return out;
  }
  std::string write(const std::vector<Eigen::VectorXd>& poses,
                    const mocapctl::BvhExportOptions& options = {}) const {
    std::ostringstream out;
    mocapctl::writeBvh(out, skeleton_, frames(poses), 0.04, options);
    return out.str();
  }
  // Every segment's world origin, as the daemon computes it.
  std::vector<Eigen::Vector3d> segmentOrigins(const Eigen::VectorXd& q) const {
    mocap::KinematicsData data(body_);
    mocap::forwardKinematics(body_, data, q);
    std::vector<Eigen::Vector3d> out;
    for (const Eigen::Isometry3d& world : data.world) out.push_back(world.translation());
    return out;
  }
  // The file's position of segment `name` in frame `f`.
  static Eigen::Vector3d jointAt(const mocap::Bvh& bvh, const std::string& name, int f) {
    const int j = bvh.skeleton.jointIndex(name);
    EXPECT_GE(j, 0) << name;
    return bvhJointPositions(bvh.skeleton, bvh.motion.frames.at(static_cast<std::size_t>(f)))
        .at(static_cast<std::size_t>(j));
  }
};

TEST_F(BvhExportTest, ParsesBackWithTheTrackersReader) {
  const fs::path path =
      fs::temp_directory_path() / ("mocap_bvh_export_" + std::to_string(::getpid()) + ".bvh");
  std::ofstream(path) << write({randomPose(1), randomPose(2), randomPose(3)});
  const mocap::Bvh bvh = mocap::loadBvh(path.string());
  fs::remove(path);
  EXPECT_EQ(bvh.motion.frames.size(), 3u);
  EXPECT_DOUBLE_EQ(bvh.motion.frame_time, 0.04);
  for (const mocap::Segment& segment : body_.segments)
    EXPECT_GE(bvh.skeleton.jointIndex(segment.name), 0) << segment.name;
  EXPECT_EQ(bvh.skeleton.channel_count, 6 + 3 * static_cast<int>(body_.segments.size() - 1));
}

// Not only the root and the head: every joint of any pose is where the daemon puts it.
TEST_F(BvhExportTest, EveryJointIsWhereTheDaemonPutsItWithYUp) {
  std::vector<Eigen::VectorXd> poses;
  for (int seed = 1; seed <= 20; ++seed) poses.push_back(randomPose(seed));
  const mocap::Bvh bvh = mocap::parseBvh(write(poses), "metres.bvh");
  for (std::size_t f = 0; f < poses.size(); ++f) {
    const std::vector<Eigen::Vector3d> world = segmentOrigins(poses[f]);
    for (std::size_t s = 0; s < body_.segments.size(); ++s) {
      EXPECT_LT((jointAt(bvh, body_.segments[s].name, static_cast<int>(f)) - yUp(world[s])).norm(),
                1e-6)
          << body_.segments[s].name << " in frame " << f;
    }
  }
}

TEST_F(BvhExportTest, AStandingBodyStandsAlongYWithItsFeetOnTheFloor) {
  const mocap::Bvh bvh = mocap::parseBvh(write({standing(1.5, -2, 0.7)}), "standing.bvh");
  const std::vector<Eigen::Vector3d> points =
      mocap::bvhJointPositions(bvh.skeleton, bvh.motion.frames[0]);
  const Eigen::Vector3d pelvis = jointAt(bvh, "pelvis", 0);
  const Eigen::Vector3d head_top =
      points[static_cast<std::size_t>(bvh.skeleton.endSiteOf(bvh.skeleton.jointIndex("head")))];
  // Upright: the head straight above the hips along +Y, at the body's 1.70 m.
  EXPECT_NEAR(pelvis.y(), 0.92, 1e-9);
  EXPECT_NEAR(head_top.y(), 1.70, 1e-9);
  EXPECT_NEAR((head_top - pelvis).normalized().y(), 1.0, 1e-9);
  // The feet: the ankles 7 cm up, the toes' End Sites (lowest points) 1.3 cm up.
  double lowest = INFINITY;
  for (const Eigen::Vector3d& p : points) lowest = std::min(lowest, p.y());
  EXPECT_NEAR(lowest, 0.0128, 1e-3);
  EXPECT_NEAR(jointAt(bvh, "l_foot", 0).y(), 0.07, 1e-9);
  // Where the daemon stands it: (1.5, -2) on its floor is x = 1.5, z = 2 in the file.
  EXPECT_NEAR(pelvis.x(), 1.5, 1e-9);
  EXPECT_NEAR(pelvis.z(), 2.0, 1e-9);
}

TEST_F(BvhExportTest, TheRootTravelsAsThePosesRootDoes) {
  std::vector<Eigen::VectorXd> poses;
  for (int f = 0; f < 50; ++f) poses.push_back(standing(0.04 * f, 0.02 * f, 0.3));  // 1.1 m/s
  const mocap::Bvh bvh = mocap::parseBvh(write(poses), "walk.bvh");
  for (int f = 0; f < 50; ++f) {
    const Eigen::Vector3d expected = yUp(Eigen::Vector3d(0.04 * f, 0.02 * f, 0.92));
    // Position channels: the root's world position, its OFFSET zero.
    EXPECT_LT((bvh.motion.frames[static_cast<std::size_t>(f)].head<3>() - expected).norm(), 1e-9);
    EXPECT_LT((jointAt(bvh, "pelvis", f) - expected).norm(), 1e-9);
  }
  EXPECT_EQ(bvh.skeleton.joints[0].offset, Eigen::Vector3d::Zero());
}

TEST_F(BvhExportTest, CentimetresAreAHundredTimesMetres) {
  const std::vector<Eigen::VectorXd> poses = {randomPose(4), randomPose(5)};
  const mocap::Bvh metres = mocap::parseBvh(write(poses), "metres.bvh");
  const mocap::Bvh centimetres =
      mocap::parseBvh(write(poses, {.y_up = true, .units_per_metre = 100}), "centimetres.bvh");
  ASSERT_EQ(metres.skeleton.joints.size(), centimetres.skeleton.joints.size());
  for (std::size_t j = 0; j < metres.skeleton.joints.size(); ++j)
    EXPECT_LT(
        (centimetres.skeleton.joints[j].offset - 100 * metres.skeleton.joints[j].offset).norm(),
        1e-6);
  for (std::size_t f = 0; f < poses.size(); ++f) {
    // The root's position channels scale, every rotation stays.
    EXPECT_LT(
        (centimetres.motion.frames[f].head<3>() - 100 * metres.motion.frames[f].head<3>()).norm(),
        1e-5);
    const Eigen::Index rotations = metres.motion.frames[f].size() - 3;
    EXPECT_LT(
        (centimetres.motion.frames[f].tail(rotations) - metres.motion.frames[f].tail(rotations))
            .cwiseAbs()
            .maxCoeff(),
        1e-6);
    const std::vector<Eigen::Vector3d> m =
        bvhJointPositions(metres.skeleton, metres.motion.frames[f]);
    const std::vector<Eigen::Vector3d> cm =
        bvhJointPositions(centimetres.skeleton, centimetres.motion.frames[f]);
    for (std::size_t j = 0; j < m.size(); ++j) EXPECT_LT((cm[j] - 100 * m[j]).norm(), 1e-4);
  }
}

TEST_F(BvhExportTest, ZUpKeepsTheDaemonsFrame) {
  const Eigen::VectorXd q = randomPose(6);
  const mocap::Bvh bvh = mocap::parseBvh(write({q}, {.y_up = false}), "zup.bvh");
  const std::vector<Eigen::Vector3d> world = segmentOrigins(q);
  for (std::size_t s = 0; s < body_.segments.size(); ++s)
    EXPECT_LT((jointAt(bvh, body_.segments[s].name, 0) - world[s]).norm(), 1e-6);
}

// A body turning on the spot through +-180 degrees: its rotation curves have no jump an animation
// tool would interpolate through the wrong way round.
TEST_F(BvhExportTest, RotationCurvesStayContinuous) {
  std::vector<Eigen::VectorXd> poses;
  for (int f = 0; f <= 200; ++f) {
    Eigen::VectorXd q = standing(0, 0, 0.05 * f);  // 10 radians: past +-180 degrees
    q[body_.dofIndex("root_pitch")] = 0.5 * std::sin(0.1 * f);
    q[body_.dofIndex("r_hip_flex")] = 1.2 * std::sin(0.07 * f);
    poses.push_back(q);
  }
  const mocap::Bvh bvh = mocap::parseBvh(write(poses), "turning.bvh");
  for (std::size_t f = 1; f < poses.size(); ++f)
    EXPECT_LT((bvh.motion.frames[f] - bvh.motion.frames[f - 1]).cwiseAbs().maxCoeff(), 10.0)
        << "frame " << f;
}

TEST_F(BvhExportTest, APoseWithTheWrongDofCountIsRefused) {
  std::ostringstream out;
  EXPECT_THROW(mocapctl::writeBvh(out, skeleton_, {{1.0, 2.0}}, 0.04), std::runtime_error);
}

}  // namespace
