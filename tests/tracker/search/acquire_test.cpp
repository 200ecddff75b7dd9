// Acquisition: the human found where its silhouettes meet, facing each way it might, from a stance
// it does not stand in; the acquiring filter tracks it from there, gives no pose while no subject
// is in view, and looks again when asked. A body without a free root is refused by name.
#include "tracker/search/acquire.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"
#include "tracker/model/builtin_models.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;
using testing_support::silhouettes;

constexpr double kDeg = M_PI / 180;

struct StrideScene {
  // Cameras around the volume (the first two 90 degrees apart, as a lab places a pair), at half
  // the paper's resolution.
  explicit StrideScene(int cameras = 2) : rig(labRig(cameras, model, Motion{truth}, 390, 290)) {}

  BodyModel model = builtinHumanModel();
  Eigen::VectorXd truth = stride(model);
  Rig rig;

  // Mid-stride, away from the origin and turned: nothing like the neutral stance at the origin.
  static Eigen::VectorXd stride(const BodyModel& model) {
    Eigen::VectorXd q = model.neutralPose();
    auto set = [&](const char* name, double value) { q[model.dofIndex(name)] = value; };
    set("root_tx", 0.8);
    set("root_ty", -0.6);
    set("root_yaw", 130 * kDeg);
    set("r_hip_flex", 25 * kDeg);
    set("l_hip_flex", -15 * kDeg);
    set("l_knee_flex", 40 * kDeg);
    set("r_shoulder_flex", -20 * kDeg);
    set("l_shoulder_flex", 25 * kDeg);
    return q;
  }
};

double headingError(double a, double b) { return std::abs(std::remainder(a - b, 2 * M_PI)); }

// Every hypothesis runs the whole trial, and no challenge follows it.
AcquiringOptions fullTrialsOnly() {
  AcquiringOptions acquiring;
  acquiring.challenge_every = 0;
  acquiring.trial_drop_margin = 0;
  return acquiring;
}

// The stride scene in 4 cameras and an acquiring filter with full trials only over the factored
// filter with the defaults for people at `evaluations` a frame (set in the constructor's body: the
// acquiring filter makes its hypotheses' filters at its first step, not when it is built).
struct AcquiringStride {
  explicit AcquiringStride(int evaluations) { options.evaluations_per_frame = evaluations; }
  StrideScene scene{4};
  std::vector<SilhouetteMask> masks = silhouettes(scene.model, scene.rig, scene.truth);
  WorkerPool pool{1};
  FilterOptions options = humanFilterDefaults();
  AcquiringFilter filter{
      scene.model,
      scene.rig,
      acquisitionStances(scene.model),
      options.likelihood,
      [this] { return makeFilter("factored", scene.model, scene.rig, options, pool); },
      fullTrialsOnly()};
};

TEST(Acquire, PlacesTheBodyWhereItsSilhouettesMeetFacingEachWayItMight) {
  StrideScene scene;
  const auto masks = silhouettes(scene.model, scene.rig, scene.truth);
  std::string why;
  const std::vector<Acquisition> found =
      acquireSubject(scene.model, scene.rig, masks, acquisitionStances(scene.model),
                     LikelihoodParams{}, AcquireOptions{}, &why);
  ASSERT_GE(found.size(), 2u) << why;
  const BodyModel& m = scene.model;
  const int x = m.dofIndex("root_tx"), y = m.dofIndex("root_ty"), yaw = m.dofIndex("root_yaw");
  const Eigen::Vector2d true_place(scene.truth[x], scene.truth[y]);
  // Two cameras hardly tell a standing body's heading (turned round, or mirrored about a
  // camera's axis, it casts nearly the same silhouettes), so several are kept, best first, at
  // least 45 degrees apart; one of them faces the truth's way.
  double nearest_heading = M_PI;
  for (std::size_t i = 0; i < found.size(); ++i) {
    EXPECT_LT((Eigen::Vector2d(found[i].q[x], found[i].q[y]) - true_place).norm(), 0.15)
        << "hypothesis " << i;  // metres
    if (i > 0) {
      EXPECT_LE(found[i].log_likelihood, found[i - 1].log_likelihood);
    }
    for (std::size_t j = 0; j < i; ++j)
      EXPECT_GE(headingError(found[i].q[yaw], found[j].q[yaw]), 45 * kDeg) << i << " " << j;
    nearest_heading = std::min(nearest_heading, headingError(found[i].q[yaw], scene.truth[yaw]));
  }
  EXPECT_LT(nearest_heading, 30 * kDeg);
}

// Turned to 40 degrees, the stride searched from the standing stance alone is best found 35
// degrees off, at a fit of 0.80; from the model's mid-stride stance, facing its own way.
TEST(Acquire, AStrideIsFoundInTheModelsStrideStanceFacingItsWay) {
  StrideScene scene(4);
  const BodyModel& m = scene.model;
  Eigen::VectorXd turned = scene.truth;
  turned[m.dofIndex("root_yaw")] = 40 * kDeg;
  const auto masks = silhouettes(m, scene.rig, turned);
  const std::vector<Acquisition> found =
      acquireSubject(m, scene.rig, masks, acquisitionStances(m), LikelihoodParams{});
  ASSERT_FALSE(found.empty());
  const int yaw = m.dofIndex("root_yaw");
  EXPECT_LT(headingError(found.front().q[yaw], turned[yaw]), 20 * kDeg);
  FullBodyEvaluator scorer(m, scene.rig, LikelihoodParams{}.points_per_circle, 1);
  EXPECT_GT(silhouetteFit(scorer.evaluate(found.front().q, masks, 0), masks), 0.9);
}

// Four cameras: from two, a static stride cannot tell which leg is forward (the filter settles on
// the mirrored stride, 100-140 mm off, from the true position and heading too).
TEST(Acquire, TheAcquiringFilterTracksTheBodyFromWhereItFoundIt) {
  AcquiringStride stride(2000);
  const StrideScene& scene = stride.scene;
  AcquiringFilter& filter = stride.filter;
  const auto& masks = stride.masks;
  KinematicsData estimated(scene.model), truth(scene.model);
  forwardKinematics(scene.model, truth, scene.truth);
  const auto true_points = pointPositions(scene.model, truth);
  auto meanError = [&](const Eigen::VectorXd& q) {
    forwardKinematics(scene.model, estimated, q);
    const auto points = pointPositions(scene.model, estimated);
    double sum = 0;
    for (std::size_t i = 0; i < points.size(); ++i) sum += (points[i] - true_points[i]).norm();
    return sum / static_cast<double>(points.size());
  };
  EXPECT_GT(meanError(scene.model.neutralPose()), 0.5);  // the stance at the origin is far off
  FrameEstimate e = filter.step(masks);
  ASSERT_TRUE(e.found) << filter.lastFailure();
  EXPECT_EQ(filter.acquisitions(), 1);
  // While the hypotheses are tried, every one is tracked and counted.
  EXPECT_GT(e.evaluations, 2 * 2000);
  for (int f = 1; f < 15; ++f) e = filter.step(masks);
  EXPECT_EQ(e.evaluations, 2000 + 1);  // one hypothesis left, and its fit
  EXPECT_LT(meanError(e.q), 0.05);     // within 50 mm on average over the joints
}

// Live, a newer frame set waiting cuts a step's refinement short. During a trial that would cut
// the later hypotheses' searches and not the first's, so the hypotheses search in full while they
// compete; the lone track left after the trial gives way.
TEST(Acquire, HypothesesOnTrialAreNotCutShortALoneTrackIs) {
  AcquiringStride stride(600);
  AcquiringFilter& filter = stride.filter;
  const auto& masks = stride.masks;
  filter.setYield([] { return true; });  // a newer set is always waiting
  FrameEstimate e = filter.step(masks);
  ASSERT_TRUE(e.found) << filter.lastFailure();
  EXPECT_FALSE(e.cut_short);
  for (int f = 1; f < 10; ++f) EXPECT_FALSE(filter.step(masks).cut_short) << f;
  EXPECT_TRUE(filter.step(masks).cut_short);  // the trial's 10 frames are over
}

TEST(Acquire, TheSilhouetteFitIsNearOneAtTheTruthAndFallsAwayFromIt) {
  StrideScene scene;
  const auto masks = silhouettes(scene.model, scene.rig, scene.truth);
  FullBodyEvaluator scorer(scene.model, scene.rig, LikelihoodParams{}.points_per_circle, 1);
  EXPECT_GT(silhouetteFit(scorer.evaluate(scene.truth, masks, 0), masks), 0.9);
  Eigen::VectorXd off = scene.truth;
  off[scene.model.dofIndex("root_tx")] += 0.3;
  EXPECT_LT(silhouetteFit(scorer.evaluate(off, masks, 0), masks), 0.6);
  const std::vector<SilhouetteMask> empty(2, SilhouetteMask(cv::Mat::zeros(290, 390, CV_8UC1)));
  EXPECT_EQ(silhouetteFit(scorer.evaluate(scene.truth, empty, 0), empty), -1.0);
}

// The subject walks out of view and comes back elsewhere: by default, a fit of 0 or less (the pose
// explains nothing) for lost_after frames is a loss.
TEST(Acquire, ALostTrackerSaysSoAndFindsTheSubjectAgain) {
  StrideScene scene(4);
  const BodyModel& m = scene.model;
  const auto masks = silhouettes(m, scene.rig, scene.truth);
  Eigen::VectorXd elsewhere = scene.truth;
  elsewhere[m.dofIndex("root_tx")] -= 1.2;
  elsewhere[m.dofIndex("root_ty")] += 0.8;
  const auto back = silhouettes(m, scene.rig, elsewhere);
  const std::vector<SilhouetteMask> empty(4, SilhouetteMask(cv::Mat::zeros(290, 390, CV_8UC1)));
  WorkerPool pool(1);
  FilterOptions options = humanFilterDefaults();
  options.evaluations_per_frame = 2000;
  AcquiringFilter filter(
      m, scene.rig, acquisitionStances(m), options.likelihood,
      [&] { return makeFilter("factored", m, scene.rig, options, pool); }, fullTrialsOnly());
  filter.reset(scene.truth);
  FrameEstimate e = filter.step(masks);
  EXPECT_GT(e.silhouette_fit, 0.9);
  for (int f = 0; f < 4; ++f) {
    e = filter.step(empty);
    EXPECT_TRUE(e.found);  // not lost yet
    EXPECT_EQ(e.silhouette_fit, -1.0);
  }
  EXPECT_EQ(filter.losses(), 0);
  e = filter.step(empty);
  EXPECT_EQ(filter.losses(), 1);
  EXPECT_FALSE(filter.step(empty).found);
  EXPECT_THAT(filter.lastFailure(), HasSubstr("no subject"));
  for (int f = 0; f < 15; ++f) e = filter.step(back);
  EXPECT_TRUE(e.found);
  EXPECT_EQ(filter.acquisitions(), 1);
  EXPECT_EQ(filter.losses(), 1);
  KinematicsData estimated(m), truth(m);
  forwardKinematics(m, estimated, e.q);
  forwardKinematics(m, truth, elsewhere);
  const auto points = pointPositions(m, estimated), true_points = pointPositions(m, truth);
  double sum = 0;
  for (std::size_t i = 0; i < points.size(); ++i) sum += (points[i] - true_points[i]).norm();
  EXPECT_LT(sum / static_cast<double>(points.size()), 0.05);  // metres, mean over the joints
}

// Tracks `frames` frames of the stride scene's truth from the body turned round.
std::pair<std::unique_ptr<AcquiringFilter>, FrameEstimate> trackFromTurned(
    const StrideScene& scene, const AcquiringOptions& acquiring, int frames) {
  const BodyModel& m = scene.model;
  const auto masks = silhouettes(m, scene.rig, scene.truth);
  Eigen::VectorXd turned = scene.truth;
  turned[m.dofIndex("root_yaw")] += M_PI;
  static WorkerPool pool(1);
  FilterOptions options = humanFilterDefaults();
  options.evaluations_per_frame = 500;
  auto filter = std::make_unique<AcquiringFilter>(
      m, scene.rig, acquisitionStances(m), options.likelihood,
      [&m, &scene, options] { return makeFilter("factored", m, scene.rig, options, pool); },
      acquiring);
  filter->reset(turned);
  FrameEstimate e;
  for (int f = 0; f < frames; ++f) e = filter->step(masks);
  return {std::move(filter), e};
}

// A track started turned round (its silhouettes fit well enough never to be lost) is replaced once
// a challenge finds the subject again facing its way; without challenges it stays wrong.
TEST(Acquire, AChallengeReplacesATrackTurnedRound) {
  StrideScene scene(4);
  const int yaw = scene.model.dofIndex("root_yaw");
  AcquiringOptions acquiring = fullTrialsOnly();
  const auto [unchallenged, stayed] = trackFromTurned(scene, acquiring, 20);
  EXPECT_EQ(unchallenged->acquisitions(), 0);
  EXPECT_GT(stayed.silhouette_fit, 0);  // not lost: nothing replaces it
  EXPECT_GT(headingError(stayed.q[yaw], scene.truth[yaw]), 90 * kDeg);
  // Challenged on the 8th frame; the trial ends on the 17th, before the next challenge.
  acquiring.challenge_every = 8;
  const auto [challenged, replaced] = trackFromTurned(scene, acquiring, 20);
  EXPECT_EQ(challenged->acquisitions(), 1);
  EXPECT_EQ(challenged->losses(), 0);
  EXPECT_LT(headingError(replaced.q[yaw], scene.truth[yaw]), 20 * kDeg);
  EXPECT_EQ(replaced.evaluations, 500 + 1);  // one hypothesis left
}

// With a drop margin the hypotheses trailing the best leave the trial early: the same challenge
// still turns the track round, and four frames into the trial only one hypothesis is left, where
// without the margin all still run.
TEST(Acquire, TrailingHypothesesLeaveTheTrialEarly) {
  StrideScene scene(4);
  const int yaw = scene.model.dofIndex("root_yaw");
  AcquiringOptions acquiring = fullTrialsOnly();
  acquiring.challenge_every = 8;
  const auto [all_run, full_trial] = trackFromTurned(scene, acquiring, 12);
  EXPECT_GT(full_trial.evaluations, 2 * (500 + 1));
  acquiring.trial_drop_margin = 40;
  const auto [raced, replaced] = trackFromTurned(scene, acquiring, 12);
  EXPECT_EQ(raced->acquisitions(), 1);
  EXPECT_EQ(replaced.evaluations, 500 + 1);
  EXPECT_LT(headingError(replaced.q[yaw], scene.truth[yaw]), 20 * kDeg);
}

// A challenge's starts stepped each on a thread of their own, beside the track, give the same
// estimates as stepped after it: each has its own filter, and the scores are summed in order.
TEST(Acquire, ConcurrentRivalsTrackAsTheSequentialOnesDo) {
  StrideScene scene(4);
  AcquiringOptions acquiring = fullTrialsOnly();  // every start joins and runs the whole trial
  acquiring.challenge_every = 8;
  const auto [sequential, one_by_one] = trackFromTurned(scene, acquiring, 12);
  acquiring.concurrent_rivals = true;
  const auto [concurrent, side_by_side] = trackFromTurned(scene, acquiring, 12);
  EXPECT_EQ(concurrent->acquisitions(), 1);
  EXPECT_GT(side_by_side.evaluations, 2 * (500 + 1));  // rivals are still on trial
  EXPECT_EQ(side_by_side.evaluations, one_by_one.evaluations);
  EXPECT_EQ(side_by_side.q, one_by_one.q);
}

// A challenge on a frame where no subject is seen (fewer than two cameras see enough) changes
// nothing: the track goes on, giving poses.
TEST(Acquire, AChallengeThatFindsNoSubjectLeavesTheTrack) {
  StrideScene scene;
  const BodyModel& m = scene.model;
  const auto masks = silhouettes(m, scene.rig, scene.truth);
  const std::vector<SilhouetteMask> empty(2, SilhouetteMask(cv::Mat::zeros(290, 390, CV_8UC1)));
  WorkerPool pool(1);
  FilterOptions options = humanFilterDefaults();
  options.evaluations_per_frame = 200;
  AcquiringOptions acquiring;
  acquiring.challenge_every = 2;
  AcquiringFilter filter(m, scene.rig, acquisitionStances(m), options.likelihood,
                         [&] { return makeFilter("factored", m, scene.rig, options, pool); },
                         acquiring);
  filter.reset(scene.truth);
  EXPECT_TRUE(filter.step(masks).found);
  EXPECT_TRUE(filter.step(empty).found);  // the challenge searches this frame
  const FrameEstimate e = filter.step(masks);
  EXPECT_TRUE(e.found);  // it found no subject: the track goes on
  EXPECT_THAT(filter.lastFailure(), HasSubstr("no subject"));
  EXPECT_EQ(filter.acquisitions(), 0);
  EXPECT_EQ(e.evaluations, 200 + 1);  // still the one track
  EXPECT_EQ(filter.losses(), 0);
}

// Something the pose does not explain (here a large blob beside the body) pulls the fit far under
// its recent level: a loss when lost_below asks for one, not otherwise.
TEST(Acquire, AFitFarUnderItsRecentLevelIsALossOnlyWhenAsked) {
  StrideScene scene;
  const BodyModel& m = scene.model;
  const auto masks = silhouettes(m, scene.rig, scene.truth);
  std::vector<SilhouetteMask> blotted;
  for (cv::Mat image : SceneRenderer(m, scene.rig).renderSilhouettes(scene.truth)) {
    image(cv::Rect(0, 0, 120, 200)).setTo(255);
    blotted.emplace_back(image);
  }
  WorkerPool pool(1);
  FilterOptions options = humanFilterDefaults();
  options.evaluations_per_frame = 400;
  auto lossesAfter = [&](double lost_below) {
    AcquiringOptions acquiring;
    acquiring.lost_below = lost_below;
    AcquiringFilter filter(
        m, scene.rig, acquisitionStances(m), options.likelihood,
        [&] { return makeFilter("factored", m, scene.rig, options, pool); }, acquiring);
    filter.reset(scene.truth);
    for (int f = 0; f < 25; ++f) filter.step(masks);  // the recent level is learnt
    for (int f = 0; f < 4; ++f) {
      const double fit = filter.step(blotted).silhouette_fit;
      EXPECT_GT(fit, 0.0);
      EXPECT_LT(fit, 0.8);
    }
    EXPECT_EQ(filter.losses(), 0);
    filter.step(blotted);
    return filter.losses();
  };
  EXPECT_EQ(lossesAfter(0.9), 1);
  EXPECT_EQ(lossesAfter(0), 0);
}

TEST(Acquire, NoSubjectInViewIsToldWithThePixelsEachCameraSees) {
  StrideScene scene;
  const auto masks = silhouettes(scene.model, scene.rig, scene.truth);
  const std::vector<SilhouetteMask> empty(2, SilhouetteMask(cv::Mat::zeros(290, 390, CV_8UC1)));
  std::string why;
  EXPECT_TRUE(acquireSubject(scene.model, scene.rig, empty, acquisitionStances(scene.model),
                             LikelihoodParams{}, AcquireOptions{}, &why)
                  .empty());
  EXPECT_THAT(why, HasSubstr("no subject: 0 camera(s)"));
  EXPECT_THAT(why, HasSubstr("pixels per camera: 0, 0"));
  // Seen by one camera only: its distance cannot be told.
  const std::vector<SilhouetteMask> one = {masks[0], empty[1]};
  EXPECT_TRUE(acquireSubject(scene.model, scene.rig, one, acquisitionStances(scene.model),
                             LikelihoodParams{}, AcquireOptions{}, &why)
                  .empty());
  EXPECT_THAT(why, HasSubstr("1 camera(s)"));

  // The acquiring filter gives no pose until the subject comes into view, then finds it.
  WorkerPool pool(1);
  FilterOptions options;
  options.evaluations_per_frame = 200;
  AcquiringFilter filter(
      scene.model, scene.rig, acquisitionStances(scene.model), options.likelihood,
      [&] { return makeFilter("factored", scene.model, scene.rig, options, pool); });
  EXPECT_FALSE(filter.step(empty).found);
  EXPECT_THAT(filter.lastFailure(), HasSubstr("no subject"));
  EXPECT_EQ(filter.acquisitions(), 0);
  EXPECT_TRUE(filter.step(masks).found);
  EXPECT_EQ(filter.lastFailure(), "");
  EXPECT_EQ(filter.acquisitions(), 1);
  // Asked to, it looks again.
  filter.reacquire();
  EXPECT_FALSE(filter.step(empty).found);
  EXPECT_TRUE(filter.step(masks).found);
  EXPECT_EQ(filter.acquisitions(), 2);
}

TEST(Acquire, ABodyWithoutAFreeRootIsRefusedByName) {
  const BodyModel hand = builtinHandModel();
  EXPECT_FALSE(canAcquire(hand));
  EXPECT_TRUE(canAcquire(builtinHumanModel()));
  const Rig rig = handRig(2, 390, 290);
  const std::vector<SilhouetteMask> masks(2, SilhouetteMask(cv::Mat::zeros(290, 390, CV_8UC1)));
  try {
    acquireSubject(hand, rig, masks, {hand.neutralPose()}, LikelihoodParams{});
    FAIL() << "the hand was acquired";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("'hand' has no free root translations"));
  }
  WorkerPool pool(1);
  EXPECT_THROW(AcquiringFilter(hand, rig, {hand.neutralPose()}, LikelihoodParams{},
                               [&] { return makeFilter("factored", hand, rig, {}, pool); }),
               std::invalid_argument);
}

// Options out of range are refused, naming the one that is wrong.
TEST(Acquire, BadOptionsAreRefusedByName) {
  StrideScene scene;
  const BodyModel& m = scene.model;
  WorkerPool pool(1);
  auto refusal = [&](const AcquiringOptions& acquiring) {
    try {
      AcquiringFilter(
          m, scene.rig, acquisitionStances(m), LikelihoodParams{},
          [&] { return makeFilter("factored", m, scene.rig, {}, pool); }, acquiring);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  AcquiringOptions acquiring;
  acquiring.trial_frames = 0;
  EXPECT_THAT(refusal(acquiring), HasSubstr("trial frames"));
  acquiring = {};
  acquiring.challenge_every = -1;
  EXPECT_THAT(refusal(acquiring), HasSubstr("challenges"));
  acquiring = {};
  acquiring.trial_drop_margin = -1;
  EXPECT_THAT(refusal(acquiring), HasSubstr("drop margin"));
  acquiring.trial_drop_margin = std::nan("");
  EXPECT_THAT(refusal(acquiring), HasSubstr("drop margin"));
  acquiring.trial_drop_margin = 40;
  EXPECT_EQ(refusal(acquiring), "accepted");
  acquiring.search.uncross = -1;
  EXPECT_THAT(refusal(acquiring), HasSubstr("uncross"));
  acquiring.search.uncross = std::nan("");
  EXPECT_THAT(refusal(acquiring), HasSubstr("uncross"));
}

}  // namespace
}  // namespace mocap
