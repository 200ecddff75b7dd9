// Calibration from a recorded session: board views rendered with known cameras are recorded as a
// session by the real Recorder, detected back through detectSession and calibrated.
#include "clients/mocapctl/session_views.h"

#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "drivers/record/recorder.h"
#include "tracker/experiments/calibration_experiment.h"

namespace {

namespace fs = std::filesystem;

class SessionViewsTest : public testing::Test {
 protected:
  void SetUp() override {
    root_ =
        fs::temp_directory_path() / ("mocap_session_views_" + std::to_string(::getpid()) + "_" +
                                     testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  // Renders the views (no extra corner noise) and records them as session "session": one frame
  // set per view, in view-name order. Returns the set sequence number of each view.
  std::map<std::string, uint64_t> recordRenderedViews(
      const mocap::CalibrationExperimentConfig& config, mocap::RenderedCalibration& rendered) {
    rendered = mocap::renderCalibrationViews(config);
    // A camera only has the views whose board it sees whole; the set then lacks its frame.
    std::set<std::string> view_names;
    for (const auto& folder : fs::directory_iterator(config.write_images))
      for (const auto& entry : fs::directory_iterator(folder.path()))
        view_names.insert(entry.path().stem().string());
    std::vector<mocap::SessionCamera> cameras;
    for (const mocap::CameraModel& c : rendered.truth)
      cameras.push_back({c.name, c.width, c.height, mocap::kPixelBgr, 25.0});
    // A queue as long as the session: the recorder drops sets rather than block a live pipeline.
    mocap::RecorderOptions options;
    options.queue_sets = view_names.size();
    options.durability = mocap::Durability::kProcessCrash;
    mocap::Recorder recorder(root_, options);
    EXPECT_TRUE(recorder.open("session", {}, cameras).ok());
    std::map<std::string, uint64_t> sequence;
    uint64_t next = 0;
    for (const std::string& view : view_names) {
      mocap::FrameSet set;
      set.sequence = next;
      set.timestamp_ns = static_cast<int64_t>(next) * 40'000'000;
      for (std::size_t c = 0; c < cameras.size(); ++c) {
        const fs::path image = fs::path(config.write_images) / cameras[c].name / (view + ".png");
        if (!fs::exists(image)) {
          set.frames.emplace_back();
          continue;
        }
        mocap::Frame frame;
        frame.camera = static_cast<int>(c);
        frame.sequence = next;
        frame.timestamp_ns = set.timestamp_ns;
        frame.image = cv::imread(image.string(), cv::IMREAD_COLOR);
        EXPECT_FALSE(frame.image.empty()) << view;
        set.frames.push_back(std::move(frame));
      }
      recorder.write(set);
      sequence[view] = next++;
    }
    EXPECT_TRUE(recorder.close().ok());
    EXPECT_EQ(recorder.stats().sets_written, view_names.size());
    return sequence;
  }

  fs::path root_;
};

TEST_F(SessionViewsTest, CalibratesRenderedCamerasFromARecordedSession) {
  mocap::CalibrationExperimentConfig config;
  config.cameras = 2;
  config.views = 20;
  config.noise_px = 0;
  config.seed = 3;
  config.write_images = (root_ / "images").string();
  mocap::RenderedCalibration rendered;
  const auto sequence = recordRenderedViews(config, rendered);

  std::vector<mocap::RejectedView> rejected;
  const auto cameras =
      mocapctl::detectSession((root_ / "session").string(), rendered.board, 1, rejected);
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0].name, rendered.truth[0].name);
  // The same views are found as the experiment's own detection of the images found.
  for (std::size_t c = 0; c < cameras.size(); ++c)
    EXPECT_EQ(cameras[c].views.size(), rendered.observations[c].views.size()) << cameras[c].name;

  mocap::CalibrationOptions options;
  options.floor_view = std::to_string(sequence.at(rendered.floor_view));
  const mocap::CalibrationResult result = mocap::calibrateRig(cameras, rendered.board, options);
  const nlohmann::json error = mocap::compareWithTruth(rendered.truth, result);
  // The targets for rendered views (met here without the experiment's added noise).
  EXPECT_LE(error["reprojection_rms_px"].get<double>(), 0.3);
  EXPECT_LE(error["focal_error_pct"].get<double>(), 0.5);
  EXPECT_LE(error["extrinsic_translation_error_mm"].get<double>(), 5.0);
}

TEST_F(SessionViewsTest, EverySecondSetHalvesTheViews) {
  mocap::CalibrationExperimentConfig config;
  config.cameras = 2;
  config.views = 10;
  config.noise_px = 0;
  config.write_images = (root_ / "images").string();
  mocap::RenderedCalibration rendered;
  recordRenderedViews(config, rendered);
  std::vector<mocap::RejectedView> rejected;
  const auto all =
      mocapctl::detectSession((root_ / "session").string(), rendered.board, 1, rejected);
  rejected.clear();
  const auto half =
      mocapctl::detectSession((root_ / "session").string(), rendered.board, 2, rejected);
  for (std::size_t c = 0; c < all.size(); ++c) {
    for (const auto& [view, detection] : half[c].views) {
      EXPECT_EQ(std::stoul(view) % 2, 0u) << view;
      EXPECT_TRUE(all[c].views.count(view)) << view;
    }
    EXPECT_LT(half[c].views.size(), all[c].views.size());
  }
}

TEST_F(SessionViewsTest, RefusesWhatIsNotASessionWithItsName) {
  const mocap::BoardSpec board{};
  std::vector<mocap::RejectedView> rejected;
  const std::string missing = (root_ / "no_such_session").string();
  try {
    mocapctl::detectSession(missing, board, 1, rejected);
    FAIL() << "expected CalibrationError";
  } catch (const mocap::CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  fs::create_directories(root_ / "garbage");
  std::ofstream(root_ / "garbage" / "manifest.yaml") << "this: [is not a manifest";
  EXPECT_THROW(mocapctl::detectSession((root_ / "garbage").string(), board, 1, rejected),
               mocap::CalibrationError);
  EXPECT_THROW(mocapctl::detectSession(missing, board, 0, rejected), mocap::CalibrationError);
}

}  // namespace
