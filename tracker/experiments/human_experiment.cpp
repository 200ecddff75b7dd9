// The human-tracking experiment.
#include "tracker/experiments/human_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <string_view>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tracker/experiments/commands.h"
#include "tracker/experiments/filter_flags.h"
#include "tracker/experiments/human_scene.h"
#include "tracker/experiments/human_scoring.h"
#include "tracker/likelihood/full_body.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/retarget.h"
#include "tracker/search/acquire.h"
#include "tracker/search/body_size.h"
#include "tracker/sim/scene.h"
#include "tracker/sim/subject.h"

namespace mocap {

namespace {

// The start pose of a recovery run: the truth, misplaced as `offset` says.
Eigen::VectorXd misplaced(const BodyModel& model, Eigen::VectorXd q, const std::string& offset) {
  if (offset == "none") return q;
  if (offset == "arm60") {
    const int d = model.dofIndex("l_shoulder_flex");
    const Dof& dof = model.dofs[d];
    const double shift = 60 * M_PI / 180;
    q[d] = q[d] + shift <= dof.max ? q[d] + shift : q[d] - shift;
    return q;
  }
  if (offset == "body30cm") {
    q[model.dofIndex("root_tx")] += 0.3;
    return q;
  }
  throw std::invalid_argument("--start-offset: expected none, arm60, body30cm or acquire, got '" +
                              offset + "'");
}

// Every camera's true silhouette (grey) with the outline of the estimate's (red), for looking at
// what the tracker got wrong: <dir>/frame<f>_<camera>.png.
void writeOverlays(const std::string& dir, int frame, const std::vector<SilhouetteMask>& masks,
                   SceneRenderer& renderer, const Eigen::VectorXd& estimate) {
  std::vector<cv::Mat> estimated;
  renderer.renderSilhouettes(estimate, estimated);
  for (std::size_t c = 0; c < masks.size(); ++c) {
    const cv::Mat grey = masks[c].toMat() / 2;
    cv::Mat image;
    cv::merge(std::vector<cv::Mat>{grey, grey, grey}, image);
    std::vector<std::vector<cv::Point>> outline;
    cv::findContours(estimated[c], outline, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    cv::drawContours(image, outline, -1, cv::Scalar(0, 0, 255), 1);
    const std::string path =
        dir + "/frame" + std::to_string(frame) + "_cam" + std::to_string(c) + ".png";
    if (!cv::imwrite(path, image))
      throw std::runtime_error("--overlay: cannot write '" + path + "'");
  }
}

void validate(const HumanExperimentConfig& config) {
  if (config.dofs != 31 && config.dofs != 17)
    throw std::invalid_argument("--dofs: expected 31 or 17");
  if (config.noise != "none" && config.noise != "realistic")
    throw std::invalid_argument("--noise: expected none or realistic, got '" + config.noise + "'");
  if (config.motion_path.empty()) throw std::invalid_argument("--motion FILE.bvh is required");
  if (!(config.speed_scale > 0))
    throw std::invalid_argument("--speed-scale: expected a positive factor");
  if (!config.overlay_dir.empty() && !std::filesystem::is_directory(config.overlay_dir))
    throw std::invalid_argument("--overlay: '" + config.overlay_dir + "' is not a directory");
  if (config.silhouettes != "true" && config.silhouettes != "extracted")
    throw std::invalid_argument("--silhouettes: expected true or extracted, got '" +
                                config.silhouettes + "'");
  if (config.silhouettes == "extracted" && config.noise != "none")
    throw std::invalid_argument("--noise realistic corrupts true silhouettes: not with extracted");
  if (config.tracked_body != "truth" && config.tracked_body != "default" &&
      config.tracked_body != "fit" && config.tracked_body != "drawn")
    throw std::invalid_argument("--tracked-body: expected truth, default, fit or drawn, got '" +
                                config.tracked_body + "'");
  if (config.reset_to != "truth" && config.reset_to != "nearest")
    throw std::invalid_argument("--reset-to: expected truth or nearest, got '" + config.reset_to +
                                "'");
  if (config.tracked_body == "drawn" && !config.subject_seed)
    throw std::invalid_argument("--tracked-body drawn: needs --subject-seed (the drawn subject)");
}

// The subject and its motion: the model file's body with the BVH's proportions (optionally all
// of it `subject_scale` times as large: a smaller or taller person moving the same way, so its
// root moves that much farther too), posed frame by frame at 25 Hz.
struct HumanSubject {
  BodyModel model;             // the subject's body (its 17 gait DOFs only, with --dofs 17)
  BodyModel unfitted;          // the model file's body (likewise)
  Motion truth;                // from --start-frame, --frames long at most
  double fit_residual_mm = 0;  // the retargeting's mean residual over those frames
};

HumanSubject loadSubject(const HumanExperimentConfig& config) {
  const BodyModel base =
      config.model_path.empty() ? builtinHumanModel() : loadBodyModel(config.model_path);
  const Bvh bvh = loadBvh(config.motion_path, config.bvh);
  const BodyModel bvh_body = fitModelToBvh(base, bvh.skeleton);
  const BodyModel fitted = scaledBodyModel(bvh_body, config.subject_scale);
  const RetargetResult retarget =
      retargetBvh(bvh_body, bvh.skeleton, bvh.motion, 25, config.start_frame + config.frames);
  HumanSubject subject{fitted, base, retarget.motion};
  Motion& truth = subject.truth;
  if (config.start_frame >= static_cast<int>(truth.size()))
    throw std::invalid_argument("--start-frame: the motion has only " +
                                std::to_string(truth.size()) + " frames at 25 Hz");
  truth.erase(truth.begin(), truth.begin() + config.start_frame);
  for (Eigen::VectorXd& q : truth)
    for (int d : fitted.segments[0].dofs)
      if (fitted.dofs[d].type == DofType::kTranslation) q[d] *= config.subject_scale;
  const int frames = std::min<int>(config.frames, static_cast<int>(truth.size()));

  // Gait mode: the 17 gait DOFs move, the rest stay neutral in the truth and in the tracker.
  if (config.dofs == 17) {
    if (fitted.gait_dofs.size() != 17)
      throw std::invalid_argument("the body model defines " +
                                  std::to_string(fitted.gait_dofs.size()) + " gait DOFs, not 17");
    const Eigen::VectorXd neutral = fitted.neutralPose();
    subject.model = freezeAllBut(fitted, fitted.gait_dofs, neutral);
    subject.unfitted = freezeAllBut(base, base.gait_dofs, neutral);
    for (Eigen::VectorXd& q : truth)
      for (std::size_t d = 0; d < subject.model.dofs.size(); ++d)
        if (!subject.model.dofs[d].isFree())
          q[static_cast<long>(d)] = neutral[static_cast<long>(d)];
  }
  truth.resize(frames);
  double residual = 0;
  int residual_count = 0;
  for (int f = 0; f < frames; ++f)
    for (double r : retarget.residual_mm[f]) residual += r, ++residual_count;
  subject.fit_residual_mm = residual_count ? residual / residual_count : 0.0;
  return subject;
}

// The body the tracker knows: the subject's own ("truth"), the model file as given ("default"),
// or that file with the proportions fitted to the subject ("fit").
struct TrackedBody {
  BodyModel body;
  std::optional<BodyFit> fit;
  double fit_seconds = 0;
};

// As a user would: the subject first stands in the model's fit pose where the motion starts,
// turning from its first heading through a quarter turn over kFitFrames frames, and the model
// file's body is fitted to it.
TrackedBody fitTrackedBody(const HumanExperimentConfig& config, const HumanSubject& subject,
                           const Rig& rig, HumanScene& renderer,
                           const LikelihoodParams& likelihood) {
  const BodyModel& unfitted = subject.unfitted;
  if (!unfitted.fit_pose)
    throw std::invalid_argument("--tracked-body fit: the body model has no fit_pose");
  const FitStance standing = fitPoseAt(unfitted, subject.truth[0]);
  std::vector<std::vector<SilhouetteMask>> fit_frames(kFitFrames);
  std::vector<cv::Mat> fit_images;
  for (int f = 0; f < kFitFrames; ++f) {
    Eigen::VectorXd turned = standing.pose;
    if (standing.turn_dof >= 0)
      turned[standing.turn_dof] += M_PI / 2 * f / std::max(1, kFitFrames - 1);
    renderer.renderSilhouettes(turned, fit_images);
    for (std::size_t c = 0; c < rig.size(); ++c) {
      // Frames before the motion's own (negative), so their defects differ from its frames'.
      if (config.noise == "realistic")
        corruptSilhouette(fit_images[c], config.seed, -1 - f, static_cast<int>(c));
      fit_frames[f].emplace_back(fit_images[c]);
    }
  }
  const auto start = std::chrono::steady_clock::now();
  std::string why_not;
  BodyFitOptions fit_options;
  fit_options.proportion_rounds = config.fit_rounds;
  std::optional<BodyFit> fit =
      fitBodyInPose(unfitted, rig, fit_frames, likelihood, fit_options, &why_not);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!fit) throw std::runtime_error("--tracked-body fit: no subject found: " + why_not);
  BodyProportions tracked = fit->proportions;
  tracked.arm_girth *= config.limb_margin;
  tracked.leg_girth *= config.limb_margin;
  return {proportionedBodyModel(unfitted, tracked), fit, seconds};
}

TrackedBody trackedBodyFor(const HumanExperimentConfig& config, const HumanSubject& subject,
                           const Rig& rig, HumanScene& renderer,
                           const LikelihoodParams& likelihood) {
  if (config.tracked_body == "default") return {subject.unfitted, std::nullopt, 0};
  if (config.tracked_body == "fit")
    return fitTrackedBody(config, subject, rig, renderer, likelihood);
  if (config.tracked_body == "drawn")
    return {proportionedBodyModel(subject.unfitted, *renderer.subjectProportions(subject.unfitted)),
            std::nullopt, 0};
  return {subject.model, std::nullopt, 0};
}

// The filter under test, and the acquiring filter around it when there is one: it finds the body
// itself, in the model's stances, as mocapd does on real cameras, at the start when there is no
// true first pose, and again when it declares itself lost.
struct TrackerUnderTest {
  std::unique_ptr<PoseFilter> filter;
  AcquiringFilter* acquiring = nullptr;
};

TrackerUnderTest makeTracker(const HumanExperimentConfig& config, const BodyModel& tracked,
                             const Rig& rig, const FilterOptions& options, WorkerPool& pool) {
  const auto makeTrackerFilter = [&] {
    return makeFilter(config.method, tracked, rig, options, pool);
  };
  if (config.start_offset != "acquire" && !config.lost_below && config.challenge_every == 0)
    return {makeTrackerFilter()};
  AcquiringOptions acquiring_options;
  acquiring_options.lost_below = config.lost_below.value_or(0);
  acquiring_options.lost_after = config.lost_after;
  acquiring_options.challenge_every = config.challenge_every;
  acquiring_options.trial_drop_margin = config.trial_drop_margin;
  acquiring_options.search.uncross = options.refine.uncross;
  auto acquiring =
      std::make_unique<AcquiringFilter>(tracked, rig, acquisitionStances(tracked),
                                        options.likelihood, makeTrackerFilter, acquiring_options);
  AcquiringFilter* borrowed = acquiring.get();
  return {std::move(acquiring), borrowed};
}

// Frame `f`'s silhouettes as the tracker gets them, with the defects the config asks for.
void renderFrame(const HumanExperimentConfig& config, int f, const Eigen::VectorXd& truth,
                 int missed_limb, HumanScene& renderer, std::vector<cv::Mat>& images,
                 std::vector<SilhouetteMask>& masks) {
  const bool realistic = config.noise == "realistic";
  // A limb missed by segmentation in one camera for 5 frames out of every 50.
  if (realistic && missed_limb >= 0 && f % 50 >= 20 && f % 50 < 25)
    renderer.hideSegment(0, missed_limb);
  renderer.renderSilhouettes(truth, images);
  renderer.clearHidden();
  const bool out_of_view = f >= config.dropout_at && f < config.dropout_at + config.dropout_frames;
  for (std::size_t c = 0; c < images.size(); ++c) {
    if (realistic) corruptSilhouette(images[c], config.seed, f, static_cast<int>(c));
    if (out_of_view) images[c].setTo(0);
    masks[c] = SilhouetteMask(images[c]);
  }
}

// The filter's settings as the output reports them.
void describeFilter(const HumanExperimentConfig& config, const FilterOptions& options,
                    nlohmann::json& out) {
  const bool refined = config.method == "factored" && options.refine.share > 0;
  const bool swap = refined && options.refine.swap.enabled;
  out["injection"] = options.injection.share;
  out["inject"] =
      options.injection.redraw == InjectionOptions::Redraw::kSegment ? "segment" : "dof";
  out["refine"] = refined ? options.refine.share : 0.0;
  out["refine_max"] = refined ? options.refine.max_evaluations : 0;
  out["refine_hold"] = refined && options.refine.hold;
  out["refine_plant"] = refined && options.refine.plant;
  out["refine_unexplained"] = refined && options.refine.unexplained;
  out["refine_swap"] = swap;
  out["refine_swap_knees_only"] = swap && options.refine.swap.knees_only;
  out["refine_swap_margin"] = swap ? options.refine.swap.margin : 0.0;
  out["refine_restart_share"] = refined ? options.refine.restart_share : 0.0;
  // Acquisition and its trials charge the crossed feet whatever the method (AcquireOptions).
  out["refine_uncross"] = options.refine.uncross;
}

void describeProportions(const BodyProportions& proportions, const char* key, nlohmann::json& out) {
  nlohmann::json named = nlohmann::json::object();
  for (int k = 0; k < BodyProportions::kCount; ++k)
    if (!std::isnan(proportions[k])) named[BodyProportions::name(k)] = proportions[k];
  out[key] = named;
}

// What a subject wears, so a run's result can be read against its outline.
nlohmann::json describeClothing(const Clothing& clothing) {
  static const char* const kLower[] = {"trousers", "loose_trousers", "skirt", "dress"};
  return {{"lower", kLower[static_cast<int>(clothing.lower)]},
          {"coat", clothing.coat},
          {"long_hair", clothing.long_hair},
          {"shoes", clothing.shoes}};
}

nlohmann::json orNull(const std::optional<int>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json();
}

// The output's fields that only some flags add (so that a run without them reports as before).
void describeOptionalFields(const HumanExperimentConfig& config, const HumanSubject& subject,
                            const HumanScene& renderer, const TrackedBody& tracked,
                            const HumanRunScore& score, nlohmann::json& out) {
  if (config.reset_every > 0) {
    out["reset_every"] = config.reset_every;
    out["reset_to"] = config.reset_to;
  }
  if (config.start_frame > 0) out["start_frame"] = config.start_frame;
  if (config.speed_scale != 1) out["speed_scale"] = config.speed_scale;
  if (config.subject_scale != 1) out["subject_scale"] = config.subject_scale;
  if (config.tracked_body != "truth") {
    out["tracked_body"] = config.tracked_body;
    out["body_floor_mm"] = score.meanBodyFloorMm();
  }
  if (tracked.fit) {
    out["body_scale"] = tracked.fit->scale;
    out["fit_rounds"] = config.fit_rounds;
    if (config.limb_margin != 1) out["limb_margin"] = config.limb_margin;
    describeProportions(tracked.fit->proportions, "body_proportions", out);
    out["body_fit_evaluations"] = tracked.fit->evaluations;
    out["body_fit_seconds"] = tracked.fit_seconds;
  }
  if (config.reportsProductPath()) {
    out["scenario"] = config.scenario.empty() ? nlohmann::json() : nlohmann::json(config.scenario);
    out["silhouettes"] = config.silhouettes;
    out["subject_seed"] =
        config.subject_seed ? nlohmann::json(*config.subject_seed) : nlohmann::json();
    out["longest_loss_frames"] = score.longestLossFrames();
    out["frames_to_first_lock"] = orNull(score.firstLockFrame());
    if (const std::optional<BodyProportions> drawn =
            renderer.subjectProportions(subject.unfitted)) {
      describeProportions(*drawn, "subject_proportions", out);
      out["subject_height_m"] = renderer.subjectParams()->height;
      out["subject_clothing"] = describeClothing(renderer.subjectParams()->clothing);
    }
    if (const auto extraction = renderer.extractionScore())
      out["extraction"] = {{"iou", extraction->iou},
                           {"person_missed", extraction->missed},
                           {"shadow_taken", extraction->shadow_taken},
                           {"room_taken", extraction->room_taken},
                           {"camera_frames", extraction->frames}};
  }
  if (config.skip_rate > 0) {
    out["skip_rate"] = config.skip_rate;
    out["tracked_frames"] = score.scoredFrames();
  }
  if (config.dropout_frames > 0) {
    out["dropout_at"] = config.dropout_at;
    out["dropout_frames"] = config.dropout_frames;
  }
  if (config.start_offset != "none") {
    out["start_offset"] = config.start_offset;
    out["recovery_frames"] = orNull(score.recoveryFrame());
    if (config.start_offset == "arm60")
      out["arm_recovery_frames"] = orNull(score.leftArmRecoveryFrame());
  }
}

}  // namespace

nlohmann::json runHumanExperiment(const HumanExperimentConfig& config) {
  validate(config);
  const HumanSubject subject = loadSubject(config);
  const BodyModel& model = subject.model;
  const Motion& truth = subject.truth;
  const int frames = static_cast<int>(truth.size());
  const Rig rig = labRig(config.cameras, model, truth);
  // The person the cameras see, in its room when silhouettes are extracted (the background is
  // learned first, with nobody in view).
  HumanScene renderer(
      model, rig, {config.subject_seed, config.silhouettes == "extracted", config.seed}, truth[0]);
  renderer.learnBackground();

  FilterOptions options = config.filter;
  options.evaluations_per_frame = config.evaluations;
  options.seed = config.seed;
  WorkerPool pool(config.threads);
  const TrackedBody tracked_body =
      trackedBodyFor(config, subject, rig, renderer, options.likelihood);
  // The model at a rate 1/k times its own has k times its speed limits per frame.
  const BodyModel tracked =
      atFrameRate(tracked_body.body, tracked_body.body.frame_rate / config.speed_scale);
  const TrackerUnderTest tracker = makeTracker(config, tracked, rig, options, pool);
  if (config.start_offset != "acquire")
    tracker.filter->reset(misplaced(model, truth[0], config.start_offset));

  SceneRenderer tracked_renderer(tracked_body.body, rig);  // draws the estimate in the overlays
  HumanRunScore score(model, tracked_body.body, rig, options.likelihood,
                      config.tracked_body != "truth", config.trace_path);
  const int missed_limb = model.segmentIndex("l_forearm");
  std::vector<cv::Mat> images;
  std::vector<SilhouetteMask> masks(rig.size());
  long evaluations = 0, renders = 0;
  int frames_without_pose = 0;  // an acquiring filter that found no subject: its q is the stance
  double tracking_seconds = 0;
  std::mt19937_64 skip_rng(config.seed ^ 0x5c1b'7a7e'0000'0000ULL);  // apart from the filter's
  for (int f = 0; f < frames; ++f) {
    if (config.skip_rate > 0 && f > 0 &&
        std::uniform_real_distribution<double>(0, 1)(skip_rng) < config.skip_rate)
      continue;
    renderFrame(config, f, truth[f], missed_limb, renderer, images, masks);
    if (config.reset_every > 0 && f > 0 && f % config.reset_every == 0)
      tracker.filter->reset(config.reset_to == "nearest" && config.tracked_body != "truth"
                                ? score.floorPose()
                                : truth[f - 1]);
    const auto start = std::chrono::steady_clock::now();
    const FrameEstimate estimate = tracker.filter->step(masks);
    tracking_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    evaluations += estimate.evaluations;
    renders += estimate.segment_renders;
    frames_without_pose += !estimate.found;
    score.add(f, truth[f], renderer.truthPoints(truth[f]), estimate.q, estimate.found, masks);
    if (!config.overlay_dir.empty() && f % 10 == 0)
      writeOverlays(config.overlay_dir, f, masks, tracked_renderer, estimate.q);
  }

  // Averages over the frames tracked (all of them unless some were skipped).
  const int scored = score.scoredFrames();
  nlohmann::json out = {
      {"experiment", "human"},
      {"motion", std::filesystem::path(config.motion_path).filename().string()},
      {"method", config.method},
      {"frames", frames},
      {"cameras", static_cast<int>(rig.size())},
      {"dofs", config.dofs},
      {"noise", config.noise},
      {"seed", config.seed},
      {"threads", pool.size()},
      {"evals_per_frame", static_cast<double>(evaluations) / scored},
      {"segment_renders_per_frame", static_cast<double>(renders) / scored},
      {"seconds_per_frame", tracking_seconds / scored},
      {"ground_truth_fit_residual_mm", subject.fit_residual_mm},
  };
  describeFilter(config, options, out);
  score.summarize(out);
  describeOptionalFields(config, subject, renderer, tracked_body, score, out);
  if (tracker.acquiring) {
    out["acquisitions"] = tracker.acquiring->acquisitions();
    std::vector<std::string> stances = {"neutral"};
    for (const Stance& stance : tracked.stances) stances.push_back(stance.name);
    out["stances"] = stances;
    out["frames_without_pose"] = frames_without_pose;
    out["lost_below"] = config.lost_below.value_or(0);
    out["lost_after"] = config.lost_after;
    out["losses"] = tracker.acquiring->losses();
    out["challenge_every"] = config.challenge_every;
    out["trial_drop_margin"] = config.trial_drop_margin;
  }
  return out;
}

HumanExperimentConfig parseHumanCommand(int argc, char** argv) {
  const Args args(argc, argv, 2, std::string(kHumanUsage) + "\n" + filterFlagsUsage("       "));
  HumanExperimentConfig config;
  const std::string scenario = args.text("scenario", "lab");
  if (scenario == "product") {
    config.tracked_body = "fit";
    config.start_offset = "acquire";
    config.silhouettes = "extracted";
    config.subject_seed = kProductSubjectSeed;
    config.cameras = 2;
    config.challenge_every = AcquiringOptions{}.challenge_every;
  } else if (scenario != "lab") {
    throw std::invalid_argument("--scenario: expected lab or product, got '" + scenario + "'");
  }
  if (args.has("scenario")) config.scenario = scenario;
  config.motion_path = args.text("motion", "");
  config.bvh.units = parseBvhUnits(args.text("motion-units", "auto"));
  config.bvh.joint_map = args.text("motion-joint-map", "");
  config.silhouettes = args.text("silhouettes", config.silhouettes);
  if (args.has("subject-seed"))
    config.subject_seed = static_cast<uint64_t>(args.integer("subject-seed", 1, 0, 1L << 62));
  config.method = args.text("method", config.method);
  config.evaluations = static_cast<int>(args.integer("evals", config.evaluations, 1, 10'000'000));
  config.cameras = static_cast<int>(args.integer("cameras", config.cameras, 1, 16));
  config.frames = static_cast<int>(args.integer("frames", config.frames, 1, 1'000'000));
  config.seed = static_cast<uint64_t>(args.integer("seed", 1, 0, 1L << 62));
  config.dofs = static_cast<int>(args.integer("dofs", config.dofs, 17, 31));
  config.noise = args.text("noise", config.noise);
  config.start_offset = args.text("start-offset", config.start_offset);
  config.start_frame = static_cast<int>(args.integer("start-frame", 0, 0, 1'000'000));
  config.threads = static_cast<int>(args.integer("threads", 0, 0, 256));
  config.reset_every = static_cast<int>(args.integer("reset-every", 0, 0, 1'000'000));
  config.reset_to = args.text("reset-to", config.reset_to);
  config.speed_scale = args.real("speed-scale", 1.0, 0.01, 100.0);
  config.subject_scale = args.real("subject-scale", 1.0, 0.5, 2.0);
  config.tracked_body = args.text("tracked-body", config.tracked_body);
  config.fit_rounds = static_cast<int>(args.integer("fit-rounds", config.fit_rounds, 0, 10));
  config.limb_margin = args.real("limb-margin", config.limb_margin, 0.5, 2.0);
  config.skip_rate = args.real("skip-rate", 0.0, 0.0, 0.9);
  if (args.has("lost-below")) config.lost_below = args.real("lost-below", 0.0, 0.0, 0.99);
  config.lost_after = static_cast<int>(args.integer("lost-after", config.lost_after, 1, 1'000'000));
  config.challenge_every =
      static_cast<int>(args.integer("challenge-every", config.challenge_every, 0, 1'000'000));
  config.trial_drop_margin = args.real("trial-drop-margin", config.trial_drop_margin, 0.0, 1e9);
  config.dropout_at = static_cast<int>(args.integer("dropout-at", 0, 0, 1'000'000));
  config.dropout_frames = static_cast<int>(args.integer("dropout-frames", 0, 0, 1'000'000));
  config.model_path = args.text("model", "");
  config.trace_path = args.text("trace", "");
  config.overlay_dir = args.text("overlay", "");
  readFilterFlags(args, config.filter);
  return config;
}

int runHumanCommand(int argc, char** argv) {
  std::cout << runHumanExperiment(parseHumanCommand(argc, argv)).dump(2) << "\n";
  return 0;
}

}  // namespace mocap
