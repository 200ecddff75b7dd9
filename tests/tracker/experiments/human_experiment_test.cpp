// The human experiment's scoring: per-limb errors point at the limb that is wrong, lost frames are
// counted by what went wrong, --reset-every restarts from the truth, --speed-scale slows only the
// tracker, --skip-rate leaves frames untracked and unscored, --tracked-body gives the tracker
// another body than the subject's, and bad flags are refused with their names.
#include "tracker/experiments/human_experiment.h"
#include "tests/shared_data.h"

#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tracker/search/body_size.h"
#include "tracker/sim/subject.h"

namespace mocap {
namespace {

const std::string kWalk = std::string(MOCAP_SHARED_DIR) + "/data/motion/cmu_131_01_walk.bvh";

// The walk's first `frames` frames in the experiment's 2 cameras, on one thread.
HumanExperimentConfig walk(int frames) {
  HumanExperimentConfig config;
  config.motion_path = kWalk;
  config.frames = frames;
  config.threads = 1;
  return config;
}

TEST(HumanExperiment, PerLimbErrorsPointAtTheMisplacedArm) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = walk(1);
  config.evaluations = 200;  // one frame cannot bring a 60-degree arm back (20-degree speed limit)
  config.start_offset = "arm60";
  const nlohmann::json out = runHumanExperiment(config);
  const nlohmann::json& limb = out["per_limb_mm"];
  ASSERT_TRUE(limb.contains("left_arm")) << limb.dump();
  const double left_arm = limb["left_arm"].get<double>();
  EXPECT_GT(left_arm, 100.0);
  for (const char* other : {"right_arm", "left_leg", "right_leg"})
    EXPECT_GT(left_arm, 3 * limb[other].get<double>()) << other << ": " << limb.dump();
  EXPECT_EQ(out["limb_lost_frames"]["left_arm"].get<int>(), 1);
  EXPECT_TRUE(out["arm_recovery_frames"].is_null());  // not back within the one frame
}

// Two frames of the walk, 2 cameras, the tracker started with the body 30 cm off.
HumanExperimentConfig bodyOffTwoFrames() {
  HumanExperimentConfig config = walk(2);
  config.start_offset = "body30cm";
  return config;
}

// --reset-every restarts the tracker from the truth of the frame before: a body 30 cm off at the
// start is back in the next frame with it, and one frame of search does not bring it back.
TEST(HumanExperiment, ResetEveryRestartsFromTheTruth) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = bodyOffTwoFrames();
  EXPECT_TRUE(runHumanExperiment(config)["recovery_frames"].is_null());
  config.reset_every = 1;
  const nlohmann::json out = runHumanExperiment(config);
  EXPECT_EQ(out["recovery_frames"], 1) << out.dump();
  EXPECT_EQ(out["reset_every"], 1);
}

// The truth's DOFs misplace a body of other lengths (the shipped one on the walk's smaller
// subject: its feet sink, every joint below the root moves); --reset-to nearest restarts it from
// its own pose nearest the true joints instead, so it starts each frame nearer.
TEST(HumanExperiment, ResetToNearestRestartsAnotherBodyFromItsNearestPose) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = walk(6);
  config.evaluations = 20;  // a step that barely moves the pose it restarted from
  config.tracked_body = "default";
  config.reset_every = 1;
  const nlohmann::json from_truth = runHumanExperiment(config);
  config.reset_to = "nearest";
  const nlohmann::json from_nearest = runHumanExperiment(config);
  EXPECT_EQ(from_truth["reset_to"], "truth");
  EXPECT_EQ(from_nearest["reset_to"], "nearest");
  // 76.6 against 84.2 mm when written (the body's floor 54.7 mm); equal if the flag did nothing.
  EXPECT_LT(from_nearest["mpjpe_mm"].get<double>(), from_truth["mpjpe_mm"].get<double>())
      << from_truth.dump() << "\n"
      << from_nearest.dump();
  config.reset_to = "elsewhere";
  EXPECT_THROW(runHumanExperiment(config), std::invalid_argument);
}

// A lost frame is put down to the first of: legs swapped, heading, a leg, an arm.
TEST(HumanExperiment, LostFramesAreCountedByWhatWentWrongFirst) {
  // left leg, right leg, worst arm (mm), heading error (degrees), legs swapped (mm)
  EXPECT_EQ(lostFrameCause(300, 280, 150, 40, 60), "legs_swapped");  // under half of 290
  EXPECT_EQ(lostFrameCause(300, 280, 150, -40, 200), "heading");
  EXPECT_EQ(lostFrameCause(300, 20, 150, 10, 400), "legs");
  EXPECT_EQ(lostFrameCause(30, 20, 150, 10, 400), "arms");
  EXPECT_EQ(lostFrameCause(30, 20, 50, 10, 400), "other");  // the trunk or head alone
  // A body without a pair of legs has no swap to measure (NaN), whatever its legs' errors.
  EXPECT_EQ(lostFrameCause(300, 280, 150, 10, NAN), "legs");
}

// Every lost frame has one cause, and with --trace (which scores the truth too) a body 30 cm off
// after one frame of search is a failure of the search: the truth outscores the estimate.
TEST(HumanExperiment, LostFramesOfABodyOffAreSearchFailures) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = bodyOffTwoFrames();
  config.trace_path = (std::filesystem::temp_directory_path() /
                       ("human_trace_" + std::to_string(getpid()) + ".csv")).string();
  const nlohmann::json out = runHumanExperiment(config);
  std::filesystem::remove(config.trace_path);
  ASSERT_EQ(out["lost_frames"], 2) << out.dump();
  int causes = 0;
  for (const auto& [cause, count] : out["lost_frame_causes"].items()) causes += count.get<int>();
  EXPECT_EQ(causes, 2) << out["lost_frame_causes"].dump();
  EXPECT_EQ(out["lost_frames_truth_ahead"], 2);
  config.trace_path.clear();
  EXPECT_FALSE(runHumanExperiment(config).contains("lost_frames_truth_ahead"));
}

// --start-offset acquire: no true first pose; the tracker finds the body itself and counts the
// evaluations of every hypothesis it tries. --start-frame starts the scene later in the motion.
TEST(HumanExperiment, AcquireFindsTheBodyFromAnyStartFrame) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = walk(2);
  config.evaluations = 300;
  config.start_offset = "acquire";
  config.start_frame = 40;
  const nlohmann::json out = runHumanExperiment(config);
  EXPECT_EQ(out["start_offset"], "acquire");
  EXPECT_EQ(out["start_frame"], 40);
  EXPECT_GT(out["evals_per_frame"].get<double>(), 2 * 300) << out.dump();
  EXPECT_LT(out["max_frame_mpjpe_mm"].get<double>(), 500) << out.dump();  // found, if not fitted
  config.start_frame = 100000;
  try {
    runHumanExperiment(config);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("--start-frame: the motion has only 208 frames"));
  }
}

// Every camera empty for 5 frames: with loss detection the tracker gives up after lost_after of
// them, gives no pose while nothing is seen, and finds the subject on return.
TEST(HumanExperiment, ASubjectOutOfViewIsLostAndFoundAgain) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = walk(9);
  config.evaluations = 300;
  config.dropout_at = 2;
  config.dropout_frames = 5;
  config.lost_below = 0;
  config.lost_after = 2;
  const nlohmann::json out = runHumanExperiment(config);
  EXPECT_EQ(out["losses"], 1) << out.dump();
  EXPECT_EQ(out["frames_without_pose"], 3);  // frames 4-6: lost on frame 3
  EXPECT_EQ(out["acquisitions"], 1);         // on frame 7, back in view
  config.lost_below.reset();                 // no detection: a pose every frame
  const nlohmann::json plain = runHumanExperiment(config);
  EXPECT_FALSE(plain.contains("losses"));
  EXPECT_FALSE(plain.contains("frames_without_pose"));
}

TEST(HumanExperiment, BadOptionsAreNamed) {
  HumanExperimentConfig config;
  config.motion_path = kWalk;
  config.overlay_dir = "/no/such/directory";
  try {
    runHumanExperiment(config);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--overlay"), std::string::npos) << e.what();
  }
  config.overlay_dir.clear();
  config.noise = "fog";
  EXPECT_THROW(runHumanExperiment(config), std::invalid_argument);
  config.noise = "none";
  config.speed_scale = 0;
  try {
    runHumanExperiment(config);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--speed-scale"), std::string::npos) << e.what();
  }
}

// The first frames of the walk tracked by the layers alone (no refinement).
HumanExperimentConfig shortWalk(int frames) {
  HumanExperimentConfig config = walk(frames);
  config.filter.refine.share = 0;
  return config;
}

// --speed-scale changes the tracker's speed limits and not the truth's: the layers alone (no
// refinement, no injection: every candidate within its speed limit of its parent) allowed a
// twentieth of the subject's speed fall behind the walk, on the same ground truth.
TEST(HumanExperiment, SpeedScaleSlowsTheTrackerNotTheTruth) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = shortWalk(25);
  config.filter.injection.share = 0;
  const nlohmann::json as_is = runHumanExperiment(config);
  config.speed_scale = 0.05;
  const nlohmann::json slowed = runHumanExperiment(config);
  EXPECT_EQ(slowed["speed_scale"], 0.05);
  EXPECT_FALSE(as_is.contains("speed_scale"));
  EXPECT_EQ(slowed["ground_truth_fit_residual_mm"], as_is["ground_truth_fit_residual_mm"]);
  EXPECT_GT(slowed["mpjpe_mm"].get<double>(), 1.2 * as_is["mpjpe_mm"].get<double>())
      << as_is["mpjpe_mm"] << " vs " << slowed["mpjpe_mm"];
}

TEST(HumanExperiment, SkippedFramesAreNeitherTrackedNorScored) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = shortWalk(20);
  config.evaluations = 300;
  const nlohmann::json every = runHumanExperiment(config);
  config.skip_rate = 0.5;
  const nlohmann::json skipping = runHumanExperiment(config);
  EXPECT_FALSE(every.contains("tracked_frames"));
  const int tracked = skipping["tracked_frames"].get<int>();
  EXPECT_GT(tracked, 1);
  EXPECT_LT(tracked, 20);
  EXPECT_EQ(skipping["frames"], 20);
  // Per tracked frame: a step spends the same budget whether or not frames were skipped before it.
  EXPECT_EQ(skipping["evals_per_frame"], every["evals_per_frame"]);
}

// The shipped body is far off the walk's (smaller) subject even at the true angles; the body
// fitted to the subject standing in the fit pose first is much nearer, with its build reported.
TEST(HumanExperiment, TheTrackedBodyIsTheSubjectsTheFilesOrOneFittedToTheSubject) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = walk(10);
  const nlohmann::json own = runHumanExperiment(config);
  config.tracked_body = "default";
  const nlohmann::json file = runHumanExperiment(config);
  config.tracked_body = "fit";
  const nlohmann::json fitted = runHumanExperiment(config);
  EXPECT_FALSE(own.contains("tracked_body"));
  EXPECT_EQ(file["tracked_body"], "default");
  EXPECT_FALSE(file.contains("body_proportions"));
  // Nearest poses of each body to the true joints: the file's is far, the fitted one near.
  EXPECT_GT(file["body_floor_mm"].get<double>(), 40.0) << file.dump();
  EXPECT_LT(fitted["body_floor_mm"].get<double>(), 0.5 * file["body_floor_mm"].get<double>());
  // Tracked over 10 frames: the file's body about 110 mm off, the fitted one under half of that.
  EXPECT_LT(fitted["mpjpe_mm"].get<double>(), 0.5 * file["mpjpe_mm"].get<double>());
  EXPECT_LT(own["mpjpe_mm"].get<double>(), fitted["mpjpe_mm"].get<double>());
  const nlohmann::json& build = fitted["body_proportions"];
  ASSERT_EQ(build.size(), static_cast<std::size_t>(BodyProportions::kCount)) << fitted.dump();
  EXPECT_LT(build["legs"].get<double>(), 1.0);  // the subject is smaller than the file's 1.75 m
  EXPECT_LT(build["arms"].get<double>(), 0.85);
  // --limb-margin: the same fit, tracked with thicker limbs, so another track.
  config.limb_margin = 1.3;
  const nlohmann::json wider = runHumanExperiment(config);
  EXPECT_EQ(wider["limb_margin"], 1.3);
  EXPECT_EQ(wider["body_proportions"], build);
  EXPECT_NE(wider["mpjpe_mm"], fitted["mpjpe_mm"]);
  config.tracked_body = "mine";
  try {
    runHumanExperiment(config);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("--tracked-body"));
  }
}

// --tracked-body drawn: the file's body with a drawn subject's own proportions (what a perfect
// fit of the proportions would give). For a subject much smaller than the file's 1.75 m body it
// can pose nearer the subject's joints (measured: 29.6 against 33.6 mm; the subject's hip joints
// sit below its pelvis joint, which no proportions of this body reproduce); it needs a drawn
// subject.
TEST(HumanExperiment, TheDrawnBodyHasTheSubjectsOwnProportions) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = walk(3);
  config.subject_seed = 110;  // 1.54 m
  config.tracked_body = "default";
  const nlohmann::json file = runHumanExperiment(config);
  config.tracked_body = "drawn";
  const nlohmann::json drawn = runHumanExperiment(config);
  EXPECT_EQ(drawn["tracked_body"], "drawn");
  EXPECT_LT(drawn["body_floor_mm"].get<double>(), file["body_floor_mm"].get<double>())
      << drawn.dump() << file.dump();
  config.subject_seed.reset();
  try {
    runHumanExperiment(config);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("--subject-seed"));
  }
}

// The scenario switch: product sets the product path's flags, each overridden by its own flag;
// lab (the default) changes nothing and only names itself.
TEST(HumanExperiment, TheScenarioSwitchSetsTheProductPath) {
  const auto parse = [](std::vector<std::string> flags) {
    flags.insert(flags.begin(), {"mocap-experiment", "human", "--motion", kWalk});
    std::vector<char*> argv;
    for (std::string& flag : flags) argv.push_back(flag.data());
    return parseHumanCommand(static_cast<int>(argv.size()), argv.data());
  };
  const HumanExperimentConfig lab = parse({});
  const HumanExperimentConfig defaults;
  EXPECT_EQ(lab.tracked_body, defaults.tracked_body);
  EXPECT_EQ(lab.start_offset, defaults.start_offset);
  EXPECT_EQ(lab.silhouettes, "true");
  EXPECT_FALSE(lab.subject_seed);
  EXPECT_FALSE(lab.reportsProductPath());  // the output of earlier runs stays as it was
  EXPECT_EQ(parse({"--scenario", "lab"}).scenario, "lab");
  const HumanExperimentConfig product = parse({"--scenario", "product", "--cameras", "3"});
  EXPECT_EQ(product.scenario, "product");
  EXPECT_EQ(product.tracked_body, "fit");
  EXPECT_EQ(product.start_offset, "acquire");
  EXPECT_EQ(product.silhouettes, "extracted");
  EXPECT_EQ(product.subject_seed, kProductSubjectSeed);
  EXPECT_EQ(product.cameras, 3);  // given explicitly
  EXPECT_EQ(product.challenge_every, AcquiringOptions{}.challenge_every);
  EXPECT_GT(product.challenge_every, 0);
  EXPECT_EQ(lab.challenge_every, 0);
  const HumanExperimentConfig other =
      parse({"--scenario", "product", "--subject-seed", "7", "--silhouettes", "true",
             "--tracked-body", "default", "--motion-units", "cm"});
  EXPECT_EQ(other.subject_seed, 7u);
  EXPECT_EQ(other.silhouettes, "true");
  EXPECT_EQ(other.tracked_body, "default");
  EXPECT_EQ(other.start_offset, "acquire");
  EXPECT_EQ(other.bvh.units, BvhUnits::kCentimetres);
  EXPECT_THROW(parse({"--scenario", "studio"}), std::invalid_argument);
  EXPECT_THROW(parse({"--motion-units", "furlong"}), std::invalid_argument);
}

// The product path on a short run: a subject unlike the model, the shipped body fitted from the
// cameras, found by acquisition, on silhouettes extracted against a learned background. The
// subject must be found and kept in view: acquired once, a pose every frame, the neck (the
// trunk's top, which a heading flip or a lost leg leaves in place) near the subject's. Bound: on
// development subject seeds 101-105 (seed 1, these settings) the neck's mean error was 32-51 mm;
// 80 mm leaves room for another subject. The whole body is not yet kept on most of those seeds
// (3 of 5 never lock: heading flips and lost legs), so this does not ask for a lock.
TEST(HumanExperiment, TheProductPathFindsAndKeepsTheSubject) {
  REQUIRE_SHARED_FILE(kWalk);
  HumanExperimentConfig config = walk(30);
  config.scenario = "product";
  config.tracked_body = "fit";
  config.start_offset = "acquire";
  config.silhouettes = "extracted";
  config.subject_seed = 106;
  config.evaluations = 800;
  const nlohmann::json out = runHumanExperiment(config);
  EXPECT_EQ(out["scenario"], "product");
  EXPECT_EQ(out["subject_seed"], 106);
  EXPECT_EQ(out["silhouettes"], "extracted");
  EXPECT_EQ(out["tracked_body"], "fit");
  ASSERT_TRUE(out.contains("subject_proportions")) << out.dump();
  ASSERT_TRUE(out.contains("body_proportions")) << out.dump();
  // What the subject wears is reported as drawn (subject 106: a skirt under a coat).
  const Clothing worn = drawSubjectParams(106).clothing;
  EXPECT_EQ(out["subject_clothing"]["lower"], "skirt");
  EXPECT_EQ(worn.lower, LowerGarment::kSkirt);
  EXPECT_EQ(out["subject_clothing"]["coat"], worn.coat);
  EXPECT_EQ(out["subject_clothing"]["long_hair"], worn.long_hair);
  EXPECT_EQ(out["acquisitions"], 1) << out.dump();
  EXPECT_EQ(out["frames_without_pose"], 0) << out.dump();
  EXPECT_LT(out["per_joint_mm"]["neck"].get<double>(), 80.0) << out.dump();
  EXPECT_LE(out["longest_loss_frames"].get<int>(), out["lost_frames"].get<int>());
  if (!out["frames_to_first_lock"].is_null()) {
    EXPECT_LT(out["frames_to_first_lock"].get<int>(), 30);
  }
}

}  // namespace
}  // namespace mocap
