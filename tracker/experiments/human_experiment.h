// The human-tracking experiment (paper §8, measured): the 31-DOF body (or its 17-DOF gait subset)
// posed by real motion capture (a CMU BVH file retargeted onto the fitted model), rendered into 2 or
// more calibrated cameras at 780x580, optionally with realistic silhouette defects, tracked by a
// filter, and scored in millimetres against the model's own joint positions.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "tracker/filters/filter.h"
#include "tracker/model/body_model.h"
#include "tracker/model/builtin_models.h"
#include "tracker/model/camera.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/motion.h"
#include "tracker/search/acquire.h"
#include "tracker/sim/scene.h"

namespace mocap {

// Silhouette defects of real extraction, deterministic in (seed, frame, camera): ragged edges,
// holes, and a shadow blob on the floor beside the feet. (A missed limb is rendered by hiding a
// segment in the SceneRenderer.)
void corruptSilhouette(cv::Mat& mask, uint64_t seed, int frame, int camera);

// What a lost frame (MPJPE over 100 mm) got wrong, the first that applies: "legs_swapped" (the
// legs' error with left and right exchanged under half their mean error), "heading" (more than 20
// degrees off), "legs" or "arms" (one over 100 mm off), else "other". Errors in mm per limb.
std::string lostFrameCause(double left_leg, double right_leg, double worst_arm,
                           double heading_error_deg, double legs_swapped);

// Frames of the subject in the fit pose, turning, that --tracked-body fit fits the body to.
inline constexpr int kFitFrames = 5;

struct HumanExperimentConfig {
  std::string motion_path;          // BVH (CMU skeleton)
  BvhLoadOptions bvh;               // units, joint map
  // The scenario named on the command line ("lab" or "product", see parseHumanCommand); empty:
  // none named. Only labels the output.
  std::string scenario;
  // The person the cameras see: the motion's body as the tracker's own cones (empty), or the
  // simulated subject drawSubjectParams(*subject_seed) (tracker/sim/subject.h), posed by the
  // motion and scored by its own joints. The tracker never reads the subject's parameters.
  std::optional<uint64_t> subject_seed;
  // "true": each camera's exact silhouette; "extracted": colour images of the person in a room
  // (wall, floor, shading, cast shadow, sensor noise; tracker/sim/test_scene.h) from which
  // SilhouetteExtractor takes it against a background learned first from kBackgroundFrames frames
  // of the empty room, as mocapd does.
  std::string silhouettes = "true";
  std::string method = "factored";
  int evaluations = kHumanEvaluations;
  int cameras = 2;
  int frames = 200;
  uint64_t seed = 1;
  int dofs = 31;                    // 31 or 17 (gait)
  std::string noise = "none";       // none | realistic
  // none | arm60 | body30cm | acquire (no true first pose: the tracker finds the body itself)
  std::string start_offset = "none";
  int start_frame = 0;  // the motion's first frames skipped: the scene starts at this one
  int threads = 0;
  // Diagnosis of the search alone: every `reset_every` frames (0: never) the filter restarts from
  // the true pose of the frame before, so errors cannot build up; 1 gives the one-step error.
  int reset_every = 0;
  // What a reset restarts from: "truth" (the true DOFs, which on a tracked body of other
  // proportions misplace it: its feet float or sink) or "nearest" (the tracked body's pose nearest
  // the true joints of the last frame scored, as body_floor_mm measures, which with --skip-rate
  // may be older than the frame before; the truth when the body is the subject's own).
  std::string reset_to = "truth";
  // The tracker's speed limits are this times the model's, by which the truth is bounded: below 1,
  // a subject who moves faster than the tracker allows; above 1, a looser motion prior.
  double speed_scale = 1;
  // The subject is the motion's own body times this (root displacements too): a smaller or taller
  // person moving the same way.
  double subject_scale = 1;
  // The body the tracker is given: "truth" (the subject's own), "default" (the model file, the
  // shipped human a 1.75 m adult's), or "fit" (the model file fitted by fitBodyInPose to
  // kFitFrames frames of the subject in its fit_pose before the motion, turning a quarter turn),
  // or "drawn" (the model file's body with the drawn subject's own proportions, as
  // subject_proportions reports them: what a perfect fit of the proportions would give).
  std::string tracked_body = "truth";
  int fit_rounds = 1;  // --tracked-body fit: BodyFitOptions::proportion_rounds
  double limb_margin = 1;  // --tracked-body fit: the fitted arm and leg girths times this, tracked
  // A live tracker that cannot keep up: each frame after the first is skipped (not tracked, not
  // scored) with this probability, from its own seeded stream, as mocapd drops the frame sets
  // that arrive while a step runs. The tracker's motion model still assumes one frame per step.
  double skip_rate = 0;
  // Loss detection (AcquiringOptions, as mocapd has it): the body is acquired again once the
  // estimate's silhouette fit has been 0 or less, or under lost_below times its recent level
  // (lost_below 0: only the former), for lost_after frames. Unset: no detection (the paper).
  std::optional<double> lost_below;
  int lost_after = 5;
  // AcquiringOptions::challenge_every (0: never): the subject acquired again every so many frames
  // and the new hypotheses tried against the track. The lab path has none; the product scenario
  // takes the acquiring filter's default.
  int challenge_every = 0;
  // AcquiringOptions::trial_drop_margin: hypotheses this far behind the best leave a trial.
  double trial_drop_margin = AcquiringOptions{}.trial_drop_margin;
  // The subject out of view: every camera's silhouette empty for dropout_frames frames from
  // frame dropout_at (the truth still moves and is still scored).
  int dropout_at = 0;
  int dropout_frames = 0;
  std::string model_path;           // empty: the built-in human
  std::string trace_path;           // per-frame CSV (error, truth and estimate scores); empty: none
  std::string overlay_dir;  // every 10th frame: truth vs estimate PNGs per camera; empty: none
  FilterOptions filter = humanFilterDefaults();  // evaluations and seed: the fields above

  // The output has the product path's fields (scenario, subject_seed, silhouettes,
  // longest_loss_frames, frames_to_first_lock, subject_proportions): a run naming a scenario, a
  // subject or extracted silhouettes.
  bool reportsProductPath() const {
    return !scenario.empty() || subject_seed.has_value() || silhouettes != "true";
  }
};

// The subject seed --scenario product draws when no --subject-seed is given.
inline constexpr uint64_t kProductSubjectSeed = 1;

// The configuration of `mocap-experiment human` from its flags (argv[2...]). --scenario lab (the
// default) leaves every default as it is; --scenario product sets --tracked-body fit,
// --start-offset acquire, --silhouettes extracted, --subject-seed 1 and --cameras 2 (780x580 at
// 25 Hz, as every run), each overridden by its own flag when given. Throws
// std::invalid_argument for a bad flag.
HumanExperimentConfig parseHumanCommand(int argc, char** argv);

nlohmann::json runHumanExperiment(const HumanExperimentConfig& config);

}  // namespace mocap
