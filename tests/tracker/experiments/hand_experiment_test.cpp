// The hand experiment end to end, small: the JSON it promises, the hand in view of every camera,
// and errors for bad inputs.
#include "tracker/experiments/hand_experiment.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include <opencv2/core.hpp>

#include "tracker/motion/motion.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

TEST(HandExperiment, TheHandStaysInsideEveryCameraOverAMotion) {
  const BodyModel model = builtinHandModel();
  const Rig rig = handRig(3);
  SceneRenderer renderer(model, rig);
  const Motion motion = generateMotion(model, 40, 3);
  for (const auto& q : motion) {
    for (const cv::Mat& image : renderer.renderSilhouettes(q)) {
      ASSERT_GT(cv::countNonZero(image), 20000);  // a large target, as in the paper's setup
      cv::Mat border = image.clone();
      border(cv::Rect(1, 1, image.cols - 2, image.rows - 2)) = 0;
      ASSERT_EQ(cv::countNonZero(border), 0);  // never cut by the image edge
    }
  }
}

TEST(HandExperiment, ReportsTheFieldsItPromises) {
  HandExperimentConfig config;
  config.frames = 8;
  config.threads = 2;
  const nlohmann::json out = runHandExperiment(config);
  for (const char* key : {"method", "frames", "evals_per_frame", "mean_relative_error",
                          "per_joint_relative_error", "forefinger_tip_relative_error",
                          "seconds_per_frame"})
    EXPECT_TRUE(out.contains(key)) << key;
  EXPECT_EQ(out["frames"], 8);
  EXPECT_DOUBLE_EQ(out["evals_per_frame"].get<double>(), 375.0);
  EXPECT_EQ(out["per_joint_relative_error"].size(), 15u);  // the 15 moving points
  EXPECT_LT(out["mean_relative_error"].get<double>(), 0.2);
}

TEST(HandExperiment, MotionFileIsUsedAndBadOnesAreRefused) {
  const BodyModel model = builtinHandModel();
  HandExperimentConfig config;
  config.motion_path = testing::TempDir() + "/hand_motion.csv";
  saveMotionCsv(config.motion_path, model, generateMotion(model, 5, 8));
  config.frames = 100;  // the file is shorter: its length wins
  EXPECT_EQ(runHandExperiment(config)["frames"], 5);

  std::ofstream(config.motion_path) << "nonsense\n1\n";
  EXPECT_THAT([&] { runHandExperiment(config); },
              ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr("unknown DOF 'nonsense'")));
}

TEST(HandExperiment, DescribeListsDofsWithLimitsAndSpeeds) {
  const nlohmann::json d = describeModel(builtinHandModel());
  ASSERT_EQ(d["dofs"].size(), 15u);
  EXPECT_EQ(d["dofs"][3]["name"], "index_mcp_flex");
  EXPECT_NEAR(d["dofs"][3]["max_speed"].get<double>(), 8 * M_PI / 180, 1e-12);
  EXPECT_EQ(d["joints"].size(), 21u);
}

}  // namespace
}  // namespace mocap
