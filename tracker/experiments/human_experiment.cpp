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

}  // namespace

nlohmann::json runHumanExperiment(const HumanExperimentConfig& config) {
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
  const bool extracted = config.silhouettes == "extracted";
  if (extracted && config.noise != "none")
    throw std::invalid_argument("--noise realistic corrupts true silhouettes: not with extracted");
  const BodyModel base =
      config.model_path.empty() ? builtinHumanModel() : loadBodyModel(config.model_path);
  const Bvh bvh = loadBvh(config.motion_path, config.bvh);
  // The subject: the BVH's own proportions, optionally all of it `subject_scale` times as large
  // (a smaller or taller person moving the same way, so its root moves that much farther too).
  const BodyModel bvh_body = fitModelToBvh(base, bvh.skeleton);
  const BodyModel fitted = scaledBodyModel(bvh_body, config.subject_scale);
  const RetargetResult retarget =
      retargetBvh(bvh_body, bvh.skeleton, bvh.motion, 25, config.start_frame + config.frames);
  Motion truth = retarget.motion;
  if (config.start_frame >= static_cast<int>(truth.size()))
    throw std::invalid_argument("--start-frame: the motion has only " +
                                std::to_string(truth.size()) + " frames at 25 Hz");
  truth.erase(truth.begin(), truth.begin() + config.start_frame);
  for (Eigen::VectorXd& q : truth)
    for (int d : fitted.segments[0].dofs)
      if (fitted.dofs[d].type == DofType::kTranslation) q[d] *= config.subject_scale;
  const int frames = std::min<int>(config.frames, static_cast<int>(truth.size()));

  // Gait mode: the 17 gait DOFs move, the rest stay neutral in the truth and in the tracker.
  BodyModel model = fitted;
  BodyModel unfitted = base;
  if (config.dofs == 17) {
    if (fitted.gait_dofs.size() != 17)
      throw std::invalid_argument("the body model defines " +
                                  std::to_string(fitted.gait_dofs.size()) + " gait DOFs, not 17");
    const Eigen::VectorXd neutral = fitted.neutralPose();
    model = freezeAllBut(fitted, fitted.gait_dofs, neutral);
    unfitted = freezeAllBut(base, base.gait_dofs, neutral);
    for (Eigen::VectorXd& q : truth)
      for (std::size_t d = 0; d < model.dofs.size(); ++d)
        if (!model.dofs[d].isFree()) q[static_cast<long>(d)] = neutral[static_cast<long>(d)];
  }
  truth.resize(frames);
  const Rig rig = labRig(config.cameras, model, truth);
  // The person the cameras see, in its room when silhouettes are extracted (the background is
  // learned first, with nobody in view).
  HumanScene renderer(model, rig, {config.subject_seed, extracted, config.seed}, truth[0]);
  renderer.learnBackground();

  FilterOptions options = config.filter;
  options.evaluations_per_frame = config.evaluations;
  options.seed = config.seed;
  WorkerPool pool(config.threads);
  // The body the tracker knows: the subject's own (every other table of docs/human.md), the
  // model file as given, or that file with the proportions fitted to the subject standing in its
  // fit pose before the motion.
  std::optional<BodyFit> body_fit;
  double body_fit_seconds = 0;
  BodyModel tracked_body = model;
  if (config.tracked_body == "default") {
    tracked_body = unfitted;
  } else if (config.tracked_body == "fit") {
    // As a user would: the subject first stands in the model's fit pose where the motion starts,
    // turning from its first heading through a quarter turn over kFitFrames frames, and the model
    // file's body is fitted to it.
    if (!unfitted.fit_pose)
      throw std::invalid_argument("--tracked-body fit: the body model has no fit_pose");
    const FitStance standing = fitPoseAt(unfitted, truth[0]);
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
    body_fit = fitBodyInPose(unfitted, rig, fit_frames, options.likelihood, {}, &why_not);
    body_fit_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!body_fit) throw std::runtime_error("--tracked-body fit: no subject found: " + why_not);
    tracked_body = proportionedBodyModel(unfitted, body_fit->proportions);
  } else if (config.tracked_body != "truth") {
    throw std::invalid_argument("--tracked-body: expected truth, default or fit, got '" +
                                config.tracked_body + "'");
  }
  // The model at a rate 1/k times its own has k times its speed limits per frame.
  const BodyModel tracked = atFrameRate(tracked_body, tracked_body.frame_rate / config.speed_scale);
  std::unique_ptr<PoseFilter> filter;
  AcquiringFilter* acquiring = nullptr;
  const auto makeTrackerFilter = [&] {
    return makeFilter(config.method, tracked, rig, options, pool);
  };
  if (config.start_offset == "acquire" || config.lost_below) {
    // The filter finds the body itself, in the model's stances, as mocapd does on real cameras:
    // at the start when there is no true first pose, and again when it declares itself lost.
    AcquiringOptions acquiring_options;
    acquiring_options.lost_below = config.lost_below.value_or(0);
    acquiring_options.lost_after = config.lost_after;
    auto owned =
        std::make_unique<AcquiringFilter>(tracked, rig, acquisitionStances(tracked),
                                          options.likelihood, makeTrackerFilter, acquiring_options);
    acquiring = owned.get();
    filter = std::move(owned);
  } else {
    filter = makeTrackerFilter();
  }
  if (config.start_offset != "acquire")
    filter->reset(misplaced(model, truth[0], config.start_offset));

  SceneRenderer tracked_renderer(tracked_body, rig);  // draws the estimate in the overlays
  const int missed_limb = model.segmentIndex("l_forearm");
  KinematicsData tracked_kin(tracked_body);
  Eigen::VectorXd floor_pose = truth[0];
  double body_floor_mm = 0;  // summed over the frames
  IkOptions floor_ik;
  floor_ik.prior_weight = 0;
  floor_ik.respect_speed_limits = false;
  std::vector<cv::Mat> images;
  std::vector<SilhouetteMask> masks(rig.size());
  std::vector<double> per_joint(model.points.size(), 0.0);
  std::vector<double> frame_error;
  std::map<std::string, int> lost_causes = {
      {"legs_swapped", 0}, {"heading", 0}, {"legs", 0}, {"arms", 0}, {"other", 0}};
  int lost_truth_ahead = 0;  // lost frames whose truth scores over 20 units above the estimate
  const std::vector<Limb> limbs = limbsOf(model);
  std::vector<std::vector<double>> limb_error(limbs.size());  // per limb, per frame
  // Limbs by name, for the lost frames' causes: an index into `limbs`, -1 if the model lacks it.
  const auto limbNamed = [&](std::string_view name) {
    for (std::size_t l = 0; l < limbs.size(); ++l)
      if (limbs[l].name == name) return static_cast<int>(l);
    return -1;
  };
  const int left_leg = limbNamed("left_leg"), right_leg = limbNamed("right_leg");
  const int left_arm = limbNamed("left_arm"), right_arm = limbNamed("right_arm");
  const auto latestError = [&](int l) { return l >= 0 ? limb_error[l].back() : 0.0; };
  long evaluations = 0, renders = 0;
  int frames_without_pose = 0;  // an acquiring filter that found no subject: its q is the stance
  double tracking_seconds = 0;
  // Per-frame trace: tells a search failure (the estimate scores below the truth) from an
  // ambiguity of the silhouettes (it scores as well or better while far off).
  std::ofstream trace;
  std::unique_ptr<FullBodyEvaluator> scorer, estimate_scorer;
  if (!config.trace_path.empty()) {
    trace.open(config.trace_path);
    if (!trace) throw std::runtime_error("--trace: cannot write '" + config.trace_path + "'");
    trace << "frame,mpjpe_mm,truth_log_likelihood,estimate_log_likelihood,heading_error_deg";
    for (const Limb& limb : limbs) trace << ',' << limb.name << "_mm";
    trace << ",legs_swapped_mm,silhouette_pixels,estimate_fit,found\n";
    scorer =
        std::make_unique<FullBodyEvaluator>(model, rig, options.likelihood.points_per_circle, 1);
    estimate_scorer = std::make_unique<FullBodyEvaluator>(tracked_body, rig,
                                                          options.likelihood.points_per_circle, 1);
  }
  // Heading: the direction of the hip axis (right hip to left hip) on the ground plane.
  const int l_hip = model.pointIndex("l_hip"), r_hip = model.pointIndex("r_hip");
  auto heading = [&](const std::vector<Eigen::Vector3d>& points) {
    const Eigen::Vector3d axis = points[l_hip] - points[r_hip];
    return std::atan2(axis.y(), axis.x());
  };
  std::mt19937_64 skip_rng(config.seed ^ 0x5c1b'7a7e'0000'0000ULL);  // apart from the filter's
  std::vector<int> tracked_frames;  // the frames stepped and scored
  for (int f = 0; f < frames; ++f) {
    if (config.skip_rate > 0 && f > 0 &&
        std::uniform_real_distribution<double>(0, 1)(skip_rng) < config.skip_rate)
      continue;
    tracked_frames.push_back(f);
    const bool realistic = config.noise == "realistic";
    // A limb missed by segmentation in one camera for 5 frames out of every 50.
    if (realistic && missed_limb >= 0 && f % 50 >= 20 && f % 50 < 25)
      renderer.hideSegment(0, missed_limb);
    renderer.renderSilhouettes(truth[f], images);
    renderer.clearHidden();
    const bool out_of_view =
        f >= config.dropout_at && f < config.dropout_at + config.dropout_frames;
    for (std::size_t c = 0; c < rig.size(); ++c) {
      if (realistic) corruptSilhouette(images[c], config.seed, f, static_cast<int>(c));
      if (out_of_view) images[c].setTo(0);
      masks[c] = SilhouetteMask(images[c]);
    }
    if (config.reset_every > 0 && f > 0 && f % config.reset_every == 0) filter->reset(truth[f - 1]);
    const auto start = std::chrono::steady_clock::now();
    const FrameEstimate estimate = filter->step(masks);
    tracking_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    evaluations += estimate.evaluations;
    renders += estimate.segment_renders;
    frames_without_pose += !estimate.found;
    const auto true_points = renderer.truthPoints(truth[f]);
    forwardKinematics(tracked_body, tracked_kin, estimate.q);
    const auto tracked_points = pointPositions(tracked_body, tracked_kin);
    double sum = 0;
    for (std::size_t p = 0; p < true_points.size(); ++p) {
      const double e = 1000 * (true_points[p] - tracked_points[p]).norm();
      per_joint[p] += e;
      sum += e;
    }
    frame_error.push_back(sum / true_points.size());
    if (config.tracked_body != "truth") {
      // The tracked body's floor: the pose of it nearest the true joints (warm-started, pulled
      // toward nothing), which no tracker can beat on this body.
      const IkResult nearest =
          fitPoseToPoints(tracked_body, true_points, floor_pose, floor_pose, floor_ik);
      floor_pose = nearest.q;
      forwardKinematics(tracked_body, tracked_kin, floor_pose);
      const auto floor_points = pointPositions(tracked_body, tracked_kin);
      double floor_sum = 0;
      for (std::size_t p = 0; p < true_points.size(); ++p)
        floor_sum += 1000 * (true_points[p] - floor_points[p]).norm();
      body_floor_mm += floor_sum / true_points.size();
    }
    for (std::size_t l = 0; l < limbs.size(); ++l) {
      double limb_sum = 0;
      for (int p : limbs[l].points) limb_sum += 1000 * (true_points[p] - tracked_points[p]).norm();
      limb_error[l].push_back(limb_sum / limbs[l].points.size());
    }
    if (!config.overlay_dir.empty() && f % 10 == 0)
      writeOverlays(config.overlay_dir, f, masks, tracked_renderer, estimate.q);
    const double heading_error =
        l_hip >= 0 && r_hip >= 0
            ? std::remainder(heading(tracked_points) - heading(true_points), 2 * M_PI) * 180 / M_PI
            : 0.0;
    const double legs_swapped =
        left_leg >= 0 && right_leg >= 0
            ? legsSwappedError(limbs[left_leg], limbs[right_leg], true_points, tracked_points)
            : NAN;
    const bool lost = frame_error.back() > 100.0;
    if (lost)
      ++lost_causes[lostFrameCause(latestError(left_leg), latestError(right_leg),
                                   std::max(latestError(left_arm), latestError(right_arm)),
                                   heading_error, legs_swapped)];
    if (scorer) {
      const double truth_score =
          logLikelihood(options.likelihood, scorer->evaluate(truth[f], masks, 0));
      const PixelCounts estimate_counts = estimate_scorer->evaluate(estimate.q, masks, 0);
      const double estimate_score = logLikelihood(options.likelihood, estimate_counts);
      lost_truth_ahead += lost && truth_score > estimate_score + 20;
      trace << f << ',' << frame_error.back() << ',' << truth_score << ',' << estimate_score << ','
            << heading_error;
      for (const auto& error : limb_error) trace << ',' << error.back();
      long silhouette_pixels = 0;
      for (const SilhouetteMask& mask : masks) silhouette_pixels += mask.total();
      trace << ',' << legs_swapped << ',' << silhouette_pixels << ','
            << silhouetteFit(estimate_counts, masks) << ',' << estimate.found << '\n';
    }
  }

  // Averages over the frames tracked (all of them unless some were skipped).
  const int scored = static_cast<int>(tracked_frames.size());
  nlohmann::json joints = nlohmann::json::object();
  for (std::size_t p = 0; p < per_joint.size(); ++p)
    joints[model.points[p].name] = per_joint[p] / scored;
  double mpjpe = 0, worst = 0, residual = 0;
  int lost = 0, recovery = -1;
  for (int i = 0; i < scored; ++i) {
    mpjpe += frame_error[i];
    worst = std::max(worst, frame_error[i]);
    lost += frame_error[i] > 100.0;
    if (recovery < 0 && frame_error[i] < 50.0) recovery = tracked_frames[i];
  }
  // Per limb: mean error, frames lost (limb error over 100 mm), and for an arm misplaced at the
  // start, the first frame that arm is back under 50 mm.
  nlohmann::json per_limb = nlohmann::json::object(), limb_lost = nlohmann::json::object();
  int arm_recovery = -1;
  for (std::size_t l = 0; l < limbs.size(); ++l) {
    double limb_sum = 0;
    int limb_lost_frames = 0;
    for (int i = 0; i < scored; ++i) {
      limb_sum += limb_error[l][i];
      limb_lost_frames += limb_error[l][i] > 100.0;
      if (config.start_offset == "arm60" && static_cast<int>(l) == left_arm && arm_recovery < 0 &&
          limb_error[l][i] < 50.0)
        arm_recovery = tracked_frames[i];
    }
    per_limb[limbs[l].name] = limb_sum / scored;
    limb_lost[limbs[l].name] = limb_lost_frames;
  }
  int residual_count = 0;
  for (int f = 0; f < frames; ++f)
    for (double r : retarget.residual_mm[f]) residual += r, ++residual_count;
  const bool refined = config.method == "factored" && options.refine.share > 0;
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
      {"injection", options.injection.share},
      {"inject",
       options.injection.redraw == InjectionOptions::Redraw::kSegment ? "segment" : "dof"},
      {"refine", refined ? options.refine.share : 0.0},
      {"refine_max", refined ? options.refine.max_evaluations : 0},
      {"refine_hold", refined && options.refine.hold},
      {"refine_plant", refined && options.refine.plant},
      {"refine_unexplained", refined && options.refine.unexplained},
      {"refine_swap", refined && options.refine.swap.enabled},
      {"refine_swap_knees_only",
       refined && options.refine.swap.enabled && options.refine.swap.knees_only},
      {"refine_swap_margin",
       refined && options.refine.swap.enabled ? options.refine.swap.margin : 0.0},
      {"refine_restart_share", refined ? options.refine.restart_share : 0.0},
      {"evals_per_frame", static_cast<double>(evaluations) / scored},
      {"segment_renders_per_frame", static_cast<double>(renders) / scored},
      {"mpjpe_mm", mpjpe / scored},
      {"per_joint_mm", joints},
      {"per_limb_mm", per_limb},
      {"limb_lost_frames", limb_lost},
      {"max_frame_mpjpe_mm", worst},
      {"lost_frames", lost},
      {"lost_frame_causes", lost_causes},
      {"seconds_per_frame", tracking_seconds / scored},
      {"ground_truth_fit_residual_mm", residual_count ? residual / residual_count : 0.0},
  };
  if (config.reset_every > 0) out["reset_every"] = config.reset_every;
  if (config.start_frame > 0) out["start_frame"] = config.start_frame;
  if (config.speed_scale != 1) out["speed_scale"] = config.speed_scale;
  if (config.subject_scale != 1) out["subject_scale"] = config.subject_scale;
  if (config.tracked_body != "truth") {
    out["tracked_body"] = config.tracked_body;
    out["body_floor_mm"] = body_floor_mm / scored;
  }
  if (body_fit) {
    out["body_scale"] = body_fit->scale;
    nlohmann::json proportions = nlohmann::json::object();
    for (int k = 0; k < BodyProportions::kCount; ++k)
      proportions[BodyProportions::name(k)] = body_fit->proportions[k];
    out["body_proportions"] = proportions;
    out["body_fit_evaluations"] = body_fit->evaluations;
    out["body_fit_seconds"] = body_fit_seconds;
  }
  if (config.reportsProductPath()) {
    // Fields of the product path's summary, left out of a run that names none of its flags so
    // that such a run's output stays as it was.
    out["scenario"] = config.scenario.empty() ? nlohmann::json() : nlohmann::json(config.scenario);
    out["silhouettes"] = config.silhouettes;
    out["subject_seed"] =
        config.subject_seed ? nlohmann::json(*config.subject_seed) : nlohmann::json();
    out["longest_loss_frames"] = longestLoss(frame_error);
    const std::optional<int> lock = firstLock(frame_error);
    out["frames_to_first_lock"] = lock ? nlohmann::json(tracked_frames[*lock]) : nlohmann::json();
    if (const std::optional<BodyProportions> subject = renderer.subjectProportions(unfitted)) {
      nlohmann::json proportions = nlohmann::json::object();
      for (int k = 0; k < BodyProportions::kCount; ++k)
        proportions[BodyProportions::name(k)] = (*subject)[k];
      out["subject_proportions"] = proportions;
      out["subject_height_m"] = renderer.subjectParams()->height;
    }
  }
  if (config.skip_rate > 0) {
    out["skip_rate"] = config.skip_rate;
    out["tracked_frames"] = scored;
  }
  // With --trace, which scores the truth as well: lost frames that are a failure of the search
  // (the truth scores higher) rather than an ambiguity of the silhouettes.
  if (scorer) out["lost_frames_truth_ahead"] = lost_truth_ahead;
  if (acquiring) {
    out["acquisitions"] = acquiring->acquisitions();
    std::vector<std::string> stances = {"neutral"};
    for (const Stance& stance : tracked.stances) stances.push_back(stance.name);
    out["stances"] = stances;
    out["frames_without_pose"] = frames_without_pose;
    out["lost_below"] = config.lost_below.value_or(0);
    out["lost_after"] = config.lost_after;
    out["losses"] = acquiring->losses();
  }
  if (config.dropout_frames > 0) {
    out["dropout_at"] = config.dropout_at;
    out["dropout_frames"] = config.dropout_frames;
  }
  if (config.start_offset != "none") {
    out["start_offset"] = config.start_offset;
    out["recovery_frames"] = recovery >= 0 ? nlohmann::json(recovery) : nlohmann::json();
    if (config.start_offset == "arm60")
      out["arm_recovery_frames"] =
          arm_recovery >= 0 ? nlohmann::json(arm_recovery) : nlohmann::json();
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
  config.speed_scale = args.real("speed-scale", 1.0, 0.01, 100.0);
  config.subject_scale = args.real("subject-scale", 1.0, 0.5, 2.0);
  config.tracked_body = args.text("tracked-body", config.tracked_body);
  config.skip_rate = args.real("skip-rate", 0.0, 0.0, 0.9);
  if (args.has("lost-below")) config.lost_below = args.real("lost-below", 0.0, 0.0, 0.99);
  config.lost_after = static_cast<int>(args.integer("lost-after", config.lost_after, 1, 1'000'000));
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
