// Fitting the body to the subject from the cameras. The body model holds one adult's proportions
// (the human: 1.75 m); a subject of another size or build cannot be matched by any pose of it, and
// its joints are placed wrong even when the silhouettes are. A few frames in which the subject was
// tracked are enough to fit it: a candidate body is scored by refining every tracked pose on its
// frame's silhouettes (a local search) and summing the refined log-likelihoods. Refining first
// matters: a pose tracked with one body fits that body, so scoring it unchanged with another would
// favour the body it was tracked with. The body is first scaled as a whole over a grid, then its
// proportions (BodyProportions) are searched one at a time from there.
#pragma once

#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tracker/likelihood/likelihood.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

// A person's build relative to a body model, each a factor on the model's own (1: as the model).
struct BodyProportions {
  double legs = 1;   // hip -> knee -> ankle -> toe
  double arms = 1;   // shoulder -> elbow -> wrist -> hand
  double trunk = 1;  // the hips' and shoulders' heights, the pelvis -> neck distance
  double head = 1;   // neck -> top of the head
  double width = 1;  // hip and shoulder widths
  // Thickness across the length, by part: the trunk's and the head's, the arms' (hands too) and
  // the legs' (feet too). Limbs vary apart from the trunk (a heavy build thickens the trunk most).
  double trunk_girth = 1;
  double arm_girth = 1;
  // The thighs' at the knee, apart from the rest of the legs': a skirt, a dress or a coat hanging
  // from the hips widens the legs' outline there and follows the knees, as a thigh drawn wide at
  // its end does. Searched before leg_girth, which then fits the legs below the garment.
  double thigh_end_girth = 1;
  double leg_girth = 1;
  static constexpr int kCount = 9;
  static constexpr int kThighEndGirth = 7;  // its index
  double& operator[](int k);
  double operator[](int k) const { return const_cast<BodyProportions&>(*this)[k]; }
  static const char* name(int k);
};

// The model with those proportions: lengths by fitModelToRestPoints (tracker/motion/retarget.h) on
// its own rest pose so changed, so the feet stay on the floor; each girth on its part's cone radii
// and ellipsoid semi-axes across the segment frame's Z (the trunk's and the head's up axis), the
// legs being the segments from those carrying the hip points down, the arms from the shoulders',
// and thigh_end_girth on the far end of the thighs' cones instead of leg_girth. Needs the human's
// 19 point names; throws std::runtime_error naming a missing one.
BodyModel proportionedBodyModel(const BodyModel& model, const BodyProportions& proportions);

// The model's fit pose standing where `placed` stands and facing its way: the root's translations
// and its rotation about world Z taken from `placed`, every other DOF the fit pose's; and the index
// of that rotation (-1 if the root has none), which a subject turning in place changes. Throws
// std::invalid_argument if the model has no fit_pose.
struct FitStance {
  Eigen::VectorXd pose;
  int turn_dof = -1;
};
FitStance fitPoseAt(const BodyModel& model, const Eigen::VectorXd& placed);

struct BodyFitOptions {
  // The whole body's scale, first: min_scale, min_scale + step, ... up to max_scale.
  double min_scale = 0.75;
  double max_scale = 1.25;
  double scale_step = 0.025;
  // Then each proportion in turn, by coordinate search from the best scale: a step that improves
  // is kept and grows, one that fails both ways halves, down to `finest_step`. 0 rounds: scale
  // only.
  int proportion_rounds = 1;
  double proportion_step = 0.05;
  double finest_step = 0.0125;
  double min_factor = 0.6, max_factor = 1.4;
  // thigh_end_girth's own bound and first step: a skirt's hem is up to about 3.5 times a bare
  // thigh's radius at the knee.
  double max_thigh_end_girth = 4;
  double thigh_end_step = 0.25;
  // Per frame and candidate body: the local search of its pose.
  int search_evaluations = 300;
  // Asked before each frame set is searched: true ends the fit with BodyFitStopped (a daemon
  // stopping does not wait seconds for it).
  std::function<bool()> should_stop;
};

// Thrown by the fits when BodyFitOptions::should_stop says so.
struct BodyFitStopped : std::runtime_error {
  BodyFitStopped() : std::runtime_error("the body fit was stopped") {}
};

struct BodyFit {
  BodyProportions proportions;  // the fitted build (all equal to scale if proportion_rounds is 0)
  double scale = 1;             // the best whole-body scale of the grid
  double log_likelihood = 0;    // of the fitted build: its refined poses' sum over the frames
  // Of each scale of the grid, in order.
  std::vector<double> scale_log_likelihoods;
  std::vector<Eigen::VectorXd> poses;  // the refined poses with the fitted build
  long evaluations = 0;                // full-body evaluations spent
};

// Fits `model` to the subject seen in `frames` (each one mask per camera of `rig`), tracked in each
// as `poses` (DOF vectors of `model`). Throws std::invalid_argument if frames and poses differ in
// number or are none, a frame does not match the rig, or the options give no candidate scale or
// no range to a proportion.
BodyFit fitBodyToSubject(const BodyModel& model, const Rig& rig,
                         const std::vector<std::vector<SilhouetteMask>>& frames,
                         const std::vector<Eigen::VectorXd>& poses,
                         const LikelihoodParams& likelihood, const BodyFitOptions& options = {});

// The body fitted to a subject standing in the model's `fit_pose` (the human: an A-pose),
// turning in place between the frame sets if it likes (a quarter turn shows the limbs from more
// sides than two cameras do): the subject is found in each frame set by acquireSubject
// (tracker/search/acquire.h) in that pose alone, then fitBodyToSubject runs on the frame sets it
// was found in. Empty, with the reason in *why_not, if it is found in none. Throws
// std::invalid_argument if the model has no fit_pose or cannot be acquired (see canAcquire), or
// as fitBodyToSubject.
std::optional<BodyFit> fitBodyInPose(const BodyModel& model, const Rig& rig,
                                     const std::vector<std::vector<SilhouetteMask>>& frames,
                                     const LikelihoodParams& likelihood,
                                     const BodyFitOptions& options = {},
                                     std::string* why_not = nullptr);

}  // namespace mocap
