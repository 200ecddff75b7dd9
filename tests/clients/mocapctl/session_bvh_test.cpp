// A recorded session as a BVH clip without a daemon: the session (recorded by the real Recorder)
// stores true poses, not tracked ones; the clip is those, on the body they are of, at the recorded
// pace, and a session without truth is refused with a message saying what to do instead.
#include "clients/mocapctl/session_bvh.h"

#include <filesystem>
#include <sstream>

#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "clients/mocapctl/bvh_export.h"
#include "drivers/record/recorder.h"
#include "tracker/model/builtin_models.h"
#include "tracker/motion/bvh.h"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kWidth = 32;
constexpr int kHeight = 24;

class SessionBvhTest : public testing::Test {
 protected:
  void SetUp() override {
    root_ =
        fs::temp_directory_path() / ("mocap_session_bvh_" + std::to_string(::getpid()) + "_" +
                                     testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  static mocap::FrameSet frameSet(uint64_t n) {
    mocap::FrameSet set;
    set.sequence = n;
    set.timestamp_ns = 1'000'000'000 + static_cast<int64_t>(n) * 40'000'000;  // 25 Hz
    mocap::Frame frame;
    frame.camera = 0;
    frame.sequence = 100 + n;
    frame.timestamp_ns = set.timestamp_ns;
    frame.image = cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(static_cast<double>(n)));
    set.frames.push_back(std::move(frame));
    return set;
  }

  // Records `truths.size()` sets, set n with truths[n] (empty: the subject out of view), the human
  // walking along +X as the truth when `with_truth`.
  fs::path record(const std::vector<Eigen::VectorXd>& truths, bool with_truth) {
    std::vector<std::string> names;
    for (const mocap::Dof& dof : body_.dofs) names.push_back(dof.name);
    mocap::SessionTracking tracking;
    tracking.body = &body_;
    if (with_truth) tracking.truth_dofs = names;
    mocap::Recorder recorder(root_);
    const std::vector<mocap::SessionCamera> cameras = {
        {"cam", kWidth, kHeight, mocap::kPixelGray, 25.0}};
    EXPECT_TRUE(recorder.open("take", {}, cameras, tracking).ok());
    for (std::size_t n = 0; n < truths.size(); ++n)
      recorder.write(frameSet(n), {100 + n, truths[n]});
    EXPECT_TRUE(recorder.close().ok());
    return recorder.sessionPath();
  }
  Eigen::VectorXd walking(int n) const {
    Eigen::VectorXd q = body_.neutralPose();
    q[body_.dofIndex("root_tx")] = 0.05 * n;    // 1.25 m/s at 25 Hz
    q[body_.dofIndex("root_yaw")] = -M_PI / 2;  // facing +X
    return q;
  }
  static std::unique_ptr<mocap::SessionReader> open(const fs::path& dir) {
    mocap::Expected<std::unique_ptr<mocap::SessionReader>> reader = mocap::SessionReader::open(dir);
    EXPECT_TRUE(reader.ok()) << reader.error();
    return reader.ok() ? std::move(reader.value()) : nullptr;
  }

  const mocap::BodyModel body_ = mocap::builtinHumanModel();
  fs::path root_;
};

// Sets 0-1 before the subject walks in, set 4 with it out of view: the clip runs from set 2 to
// set 6, set 4 holding set 3's pose, at the recorded 25 Hz.
TEST_F(SessionBvhTest, TheClipIsTheRecordedTruthAtTheRecordedPace) {
  std::vector<Eigen::VectorXd> truths = {{}, {}};
  for (int n = 2; n <= 6; ++n) truths.push_back(n == 4 ? Eigen::VectorXd() : walking(n));
  const std::unique_ptr<mocap::SessionReader> session = open(record(truths, true));
  ASSERT_TRUE(session);
  const mocapctl::BvhClip clip = mocapctl::truthClip(*session);
  EXPECT_EQ(clip.skeleton.model_name(), "human");
  EXPECT_EQ(clip.skeleton.dofs_size(), static_cast<int>(body_.dofs.size()));
  ASSERT_EQ(clip.frames.size(), 5u);
  EXPECT_EQ(clip.held_sets, 1);
  EXPECT_NEAR(clip.frame_time_s, 0.04, 1e-12);
  const std::vector<int> from_set = {2, 3, 3, 5, 6};
  for (std::size_t f = 0; f < clip.frames.size(); ++f) {
    const Eigen::VectorXd expected = walking(from_set[f]);
    EXPECT_EQ(clip.frames[f],
              std::vector<double>(expected.data(), expected.data() + expected.size()))
        << "frame " << f;
  }

  // Written as BVH: the body walks along the file's +X, upright along +Y.
  std::ostringstream out;
  mocapctl::writeBvh(out, clip.skeleton, clip.frames, clip.frame_time_s);
  const mocap::Bvh bvh = mocap::parseBvh(out.str(), "session.bvh");
  const int pelvis = bvh.skeleton.jointIndex("pelvis");
  const int head = bvh.skeleton.jointIndex("head");
  for (std::size_t f = 0; f < clip.frames.size(); ++f) {
    const std::vector<Eigen::Vector3d> p =
        mocap::bvhJointPositions(bvh.skeleton, bvh.motion.frames[f]);
    EXPECT_NEAR(p[static_cast<std::size_t>(pelvis)].x(), 0.05 * from_set[f], 1e-9);
    EXPECT_NEAR(p[static_cast<std::size_t>(head)].y(), 0.92 + 0.17 + 0.34, 1e-9);
  }
}

TEST_F(SessionBvhTest, ASessionWithoutTruthIsRefusedSayingWhatItStores) {
  const std::unique_ptr<mocap::SessionReader> session =
      open(record({walking(0), walking(1)}, false));
  ASSERT_TRUE(session);
  try {
    mocapctl::truthClip(*session);
    FAIL() << "no exception";
  } catch (const std::runtime_error& error) {
    EXPECT_THAT(error.what(), HasSubstr("no true poses"));
    EXPECT_THAT(error.what(), HasSubstr("mocapd --replay"));
  }
}

// The wire skeleton of a body model is the one GetSkeleton sends: same tree, DOFs and points.
TEST_F(SessionBvhTest, TheSkeletonOfABodyIsItsTreeDofsAndPoints) {
  const mocap::v1::Skeleton skeleton = mocapctl::skeletonOf(body_);
  ASSERT_EQ(skeleton.segments_size(), static_cast<int>(body_.segments.size()));
  ASSERT_EQ(skeleton.dofs_size(), static_cast<int>(body_.dofs.size()));
  ASSERT_EQ(skeleton.points_size(), static_cast<int>(body_.points.size()));
  const int chest = body_.segmentIndex("chest");
  EXPECT_EQ(skeleton.segments(chest).parent(), body_.segmentIndex("pelvis"));
  EXPECT_DOUBLE_EQ(skeleton.segments(chest).rest_offset().z(), 0.17);
  EXPECT_EQ(skeleton.dofs(0).type(), mocap::v1::Dof::TRANSLATION);
  EXPECT_EQ(skeleton.dofs(body_.dofIndex("root_yaw")).type(), mocap::v1::Dof::ROTATION);
}

}  // namespace
