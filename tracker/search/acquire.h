// Finding the subject without being told where it stands: the pose a tracker starts from (or
// restarts from once lost) when no true first pose is known, as with real cameras.
//
// The paper starts its tracker at a known pose. A capture volume only knows its silhouettes, so
// the subject is placed where they meet: the rays through each camera's silhouette centroid are
// triangulated, the body in each of a few assumed stances (standing with arms down, and those its
// model lists: mid-stride, crouching) is put with its centroid there, facing each of several
// headings, and the best headings, each in its best stance (one of them turned round: a standing
// body looks much the same either way) are searched locally on the full-body likelihood,
// first the root's place and heading, then every DOF, and the better fit wins. The filter then
// tracks from it as it recovers from any misplaced pose (paper §8.3).
#pragma once

#include <string>
#include <vector>

#include <functional>
#include <future>
#include <memory>
#include <optional>

#include "tracker/filters/filter.h"
#include "tracker/filters/refine/uncross.h"
#include "tracker/likelihood/full_body.h"
#include "tracker/likelihood/likelihood.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

struct AcquireOptions {
  int headings = 12;             // over a full turn, tried at the triangulated position
  int searched_headings = 4;     // the best ones at least 60 degrees apart, each searched locally
  int search_evaluations = 120;  // per searched heading: the root's place and heading
  int fit_evaluations = 600;     // per searched heading, then: every free DOF
  long min_silhouette_pixels = 400;  // a camera with fewer sees no subject
  // The weight of the crossed feet's cost (FilterOptions::refine_uncross, the tracker's), charged
  // to every pose scored here and, by AcquiringFilter, to every estimate a trial sums: a
  // hypothesis crossed to fit the silhouettes must not win on them. 0: none.
  double uncross = 0;
};

struct Acquisition {
  Eigen::VectorXd q;                  // the stance, placed, turned and fitted
  double log_likelihood = 0;          // of q, as the filters score a whole body
  Eigen::Vector3d silhouette_centre;  // where the centroid rays met (world, metres)
  int evaluations = 0;                // full-body evaluations spent on all hypotheses
};

// The poses acquisition tries the subject in: the neutral pose, then each of the model's stances.
std::vector<Eigen::VectorXd> acquisitionStances(const BodyModel& model);

// The subject seen by `masks` (one per camera of `rig`), in the best of `stances` (at least one)
// with the root's position and heading replaced, then fitted: one hypothesis per searched
// heading, best first. Empty, with the reason in *why_not, when fewer than two cameras see enough
// silhouette or their rays cannot place it. Throws std::invalid_argument if the model's root has
// no free translations along X and Y and rotation about Z (the hand: its palm is fixed), or the
// masks do not match the rig.
std::vector<Acquisition> acquireSubject(const BodyModel& model, const Rig& rig,
                                        const std::vector<SilhouetteMask>& masks,
                                        const std::vector<Eigen::VectorXd>& stances,
                                        const LikelihoodParams& likelihood,
                                        const AcquireOptions& options = {},
                                        std::string* why_not = nullptr);

// How well a pose explains the silhouettes, comparable across frames, cameras and sessions:
// (silhouette pixels covered - footprint pixels off the silhouette) / silhouette pixels, all
// cameras together, from the full-body counts. 1 is a perfect match; the true pose of clean
// synthetic silhouettes scores about 0.97. Floored at -1, which is also the fit when no camera
// sees anything.
double silhouetteFit(const PixelCounts& counts, const std::vector<SilhouetteMask>& masks);

struct AcquiringOptions {
  // Frames each hypothesis is tracked before the best is kept (a standing body's silhouettes
  // hardly tell which way it faces; a moving one's soon do).
  int trial_frames = 10;
  // The tracker declares itself lost, and acquires the subject again, when for `lost_after`
  // frames in a row the estimate's silhouetteFit is 0 or less (it explains nothing: the subject
  // left the view, or the track did), or, if `lost_below` is not 0, under `lost_below` times its
  // recent level. That level is the median fit of the last 50 frames that were not low, learnt
  // anew for 25 frames from every acquisition: relative, because what a good fit is depends on
  // the silhouettes (about 0.97 clean and synthetic, 0.70 with shadows and holes).
  double lost_below = 0;
  int lost_after = 5;
  // Every `challenge_every` frames (0: never) that end with one track decided, the subject is
  // acquired again on that frame, beside the track on another thread, and from the next frame the
  // new hypotheses are tried against it as after a loss (the track first, so it wins ties). A track
  // that has settled on a wrong pose that still fits (turned round, the legs exchanged, a leg
  // inside the other's silhouette) is not lost by its fit, and nothing else would replace it. It
  // costs an acquisition and, for trial_frames frames, a filter per hypothesis (most of them raced
  // off at once: trial_drop_margin). Every 10 frames with the margin below, on the product path's
  // held-out runs: 26.7 +- 5.1 mm a run better than none, for 40 % more segment renders
  // (docs/human.md).
  int challenge_every = 10;
  // During a trial, a hypothesis whose summed log-likelihood falls more than this behind the best
  // one's is dropped, and the trial ends when one is left (0: every hypothesis runs the whole
  // trial). A new hypothesis's first score is its acquisition's, so one already that far behind
  // the track or the best new one never runs. Most hypotheses, a challenge's above all, trail from
  // the start; racing them off makes a trial cost little more than the track. 40 is 2,000 pixels
  // at the likelihood's beta of 0.02.
  double trial_drop_margin = 40;
  // The hypotheses a challenge adds step their first frame each on a thread of its own, beside
  // the track, instead of after it: that frame is a trial's slowest, the track and every rival in
  // full. Results are the same either way (each hypothesis has its own filter; the scores are
  // summed in the same order). Only for filters that share nothing else: their factory's worker
  // pool must have one thread, as the daemon's does with `threads: 1`.
  bool concurrent_rivals = false;
  AcquireOptions search;
};

// A filter that finds the subject itself. Its first step (and the first after reacquire()) calls
// acquireSubject on the frame; each hypothesis is then tracked by its own filter for
// `trial_frames` frames, and the one whose estimates scored best in total is kept. Meanwhile each
// step gives the estimate of the hypothesis ahead so far, and its evaluations count every
// hypothesis's. A frame in which no subject is found gives found = false, and the next one tries
// again. reset(q0) starts from a known pose instead, with no acquisition. Every estimate carries
// its silhouetteFit (one more full-body evaluation, counted); once the tracker is lost, the
// filter it was tracking with stays one of the hypotheses of the acquisition that follows, so a
// false alarm costs evaluations, not the track. A challenge (challenge_every) is such an
// acquisition without a loss, searched while the tracker waits for the next frame; the results
// do not depend on when it finishes.
class AcquiringFilter final : public PoseFilter {
 public:
  using FilterFactory = std::function<std::unique_ptr<PoseFilter>()>;
  // The model and rig are borrowed. `stances`: the poses the subject may be found in
  // (acquisitionStances).
  AcquiringFilter(const BodyModel& model, const Rig& rig, std::vector<Eigen::VectorXd> stances,
                  const LikelihoodParams& likelihood, FilterFactory make_filter,
                  const AcquiringOptions& options = {});

  std::string name() const override;
  void reset(const Eigen::VectorXd& q0) override;
  FrameEstimate step(const std::vector<SilhouetteMask>& masks) override;
  void setYield(std::function<bool()> newer_frame_waiting) override;

  // The next step finds the subject again, forgetting what is being tracked.
  void reacquire();
  // Acquisitions that found a subject so far (challenges included); times the tracker declared
  // itself lost; why the last attempt found none ("" if it did).
  int acquisitions() const { return acquisitions_; }
  int losses() const { return losses_; }
  const std::string& lastFailure() const { return last_failure_; }

 private:
  struct Hypothesis {
    std::unique_ptr<PoseFilter> filter;
    double score = 0;  // the sum of its estimates' log-likelihoods
    // Until its first step, a new hypothesis's acquisition log-likelihood on that frame.
    std::optional<double> entry;
  };

  // A challenge's acquisition, and the track's log-likelihood on the frame it searched.
  struct Challenge {
    std::vector<Acquisition> found;
    std::string why_not;
    double track_score = 0;
  };

  Hypothesis newHypothesis(const Eigen::VectorXd& q0, std::optional<double> entry = {});
  // Whether the tracker is lost after an estimate of this fit (options_.lost_below).
  bool lostAfter(double fit);

  const BodyModel& model_;
  const Rig& rig_;
  std::vector<Eigen::VectorXd> stances_;
  LikelihoodParams likelihood_;
  FilterFactory make_filter_;
  AcquiringOptions options_;
  FullBodyEvaluator scorer_;
  CrossedLegs crossed_;      // options_.search.uncross's cost, charged to the trials' scores
  KinematicsData crossing_;  // scratch of that cost
  std::function<bool()> yield_;
  std::vector<Hypothesis> hypotheses_;  // one once decided, several during a trial
  bool searching_ = true;  // the next step acquires (hypotheses_ holds the lost filter, if any)
  int trial_frames_left_ = 0;
  long steps_ = 0;  // since construction or reset(): challenges fall on its multiples
  std::vector<double> recent_fits_;  // the fits the recent level is the median of, oldest first
  int low_fit_frames_ = 0;           // consecutive estimates under it
  int acquisitions_ = 0;
  int losses_ = 0;
  std::string last_failure_;
  // Last, so it is waited for before the members its search reads go.
  std::future<Challenge> challenge_;
};

// True if acquireSubject can place this model (free root X and Y translations and Z rotation);
// else why not, naming the model.
bool canAcquire(const BodyModel& model);
std::string whyCannotAcquire(const BodyModel& model);

}  // namespace mocap
