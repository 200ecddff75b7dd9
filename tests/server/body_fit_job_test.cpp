// The body-fit job behind FitBody, driven as the pipeline's mask thread drives it: a fit takes
// only frame sets with every camera's frame, so a camera that drops or delays frames cannot hand
// it a silhouette of another instant, or none.
#include "server/body_fit_job.h"

#include <gtest/gtest.h>

#include <chrono>
#include <future>

#include <opencv2/core.hpp>

#include "server/recording_control.h"
#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/model/builtin_models.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

TEST(BodyFitJob, TakesOnlyFrameSetsWithEveryCamera) {
  const BodyModel human = builtinHumanModel();
  ASSERT_TRUE(human.fit_pose);
  const Eigen::VectorXd standing = human.stancePose(*human.fit_pose);
  const Rig rig = labRig(2, human, Motion{standing});
  const std::vector<SilhouetteMask> complete = testing_support::silhouettes(human, rig, standing);
  // A set camera 1 is missing from at the start: it has no silhouette yet.
  std::vector<SilhouetteMask> incomplete = complete;
  incomplete[1] = SilhouetteMask(cv::Mat::zeros(rig[1].height, rig[1].width, CV_8UC1));

  const ServerConfig config;
  RecordingControl recording(config, rig, {}, {}, {});
  // At 2 frame sets a second the job keeps every set it is handed (one each 0.5 s).
  BodyFitJob job(config, human, rig, nullptr, 2.0, recording);
  job.open();
  std::promise<FitBodyResult> answer;
  job.request(2, false, [&](const FitBodyResult& result) { answer.set_value(result); });
  job.poll();  // the mask thread takes the request
  for (int k = 0; k < 3; ++k) job.add(incomplete, false);
  std::future<FitBodyResult> fitted = answer.get_future();
  // Nothing collected yet, so no fit started.
  EXPECT_EQ(fitted.wait_for(std::chrono::milliseconds(0)), std::future_status::timeout);
  job.add(complete, true);
  job.add(complete, true);
  ASSERT_EQ(fitted.wait_for(std::chrono::minutes(5)), std::future_status::ready);
  const FitBodyResult result = fitted.get();
  EXPECT_EQ(result.error, BodyFitError::kNone) << result.message;
  // Found in both sets: had it taken the first two, camera 1 would have shown nobody.
  EXPECT_EQ(result.frame_sets_used, 2);
  for (int k = 0; k < BodyProportions::kCount; ++k) {
    // The thighs narrower at the knee hide under the shins' start, so only no garment is asked.
    if (k == BodyProportions::kThighEndGirth)
      EXPECT_LT(result.fit.proportions[k], 1.05);
    else
      EXPECT_NEAR(result.fit.proportions[k], 1.0, 0.05) << BodyProportions::name(k);
  }
  job.close();
  job.stop();
}

}  // namespace
}  // namespace mocap
