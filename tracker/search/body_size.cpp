// The subject's build from its silhouettes: the whole body's scale over a grid, then each
// proportion by coordinate search, every candidate scored on its locally refined poses.
#include "tracker/search/body_size.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "tracker/likelihood/full_body.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/retarget.h"
#include "tracker/search/acquire.h"
#include "tracker/search/pose_search.h"

namespace mocap {

double& BodyProportions::operator[](int k) {
  double* const factors[kCount] = {&legs,        &arms,      &trunk,           &head,     &width,
                                   &trunk_girth, &arm_girth, &thigh_end_girth, &leg_girth};
  if (k < 0 || k >= kCount) throw std::out_of_range("body proportion index");
  return *factors[k];
}

const char* BodyProportions::name(int k) {
  static const char* const kNames[kCount] = {
      "legs",        "arms",      "trunk",           "head",     "width",
      "trunk_girth", "arm_girth", "thigh_end_girth", "leg_girth"};
  return kNames[k];
}

BodyModel proportionedBodyModel(const BodyModel& model, const BodyProportions& proportions) {
  KinematicsData kinematics(model);
  forwardKinematics(model, kinematics, model.neutralPose());
  const std::vector<Eigen::Vector3d> rest = pointPositions(model, kinematics);
  auto index = [&](const std::string& name) {
    const int p = model.pointIndex(name);
    if (p < 0)
      throw std::runtime_error("body model '" + model.name + "' has no point '" + name + "'");
    return p;
  };
  const Eigen::Vector3d lateral = (rest[index("l_hip")] - rest[index("r_hip")]).normalized();
  std::vector<Eigen::Vector3d> target = rest;
  // Each point placed from the one before it on its chain, the bone between them scaled.
  auto chain = [&](const std::string& from, const std::string& to, double factor) {
    target[index(to)] = target[index(from)] + factor * (rest[index(to)] - rest[index(from)]);
  };
  // Across the body by the width, the rest (mostly up) by the trunk.
  auto across = [&](const std::string& from, const std::string& to) {
    const Eigen::Vector3d bone = rest[index(to)] - rest[index(from)];
    const Eigen::Vector3d side = lateral * lateral.dot(bone);
    target[index(to)] =
        target[index(from)] + proportions.width * side + proportions.trunk * (bone - side);
  };
  chain("pelvis", "neck", proportions.trunk);
  chain("neck", "head_top", proportions.head);
  for (const std::string side : {"l_", "r_"}) {
    across("pelvis", side + "hip");
    chain(side + "hip", side + "knee", proportions.legs);
    chain(side + "knee", side + "ankle", proportions.legs);
    chain(side + "ankle", side + "toe", proportions.legs);
    across("neck", side + "shoulder");
    chain(side + "shoulder", side + "elbow", proportions.arms);
    chain(side + "elbow", side + "wrist", proportions.arms);
    chain(side + "wrist", side + "hand", proportions.arms);
  }
  BodyModel fitted = fitModelToRestPoints(model, target);
  std::vector<double> girth(fitted.segments.size(), proportions.trunk_girth);
  // A limb: the segment carrying its first point and every segment below it.
  auto limb = [&](const std::string& first_point, double factor) {
    const int root = model.points[index(first_point)].segment;
    for (std::size_t s = 0; s < girth.size(); ++s)
      for (int a = static_cast<int>(s); a >= 0; a = fitted.segments[a].parent)
        if (a == root) {
          girth[s] = factor;
          break;
        }
  };
  for (const std::string side : {"l_", "r_"}) {
    limb(side + "hip", proportions.leg_girth);
    limb(side + "shoulder", proportions.arm_girth);
  }
  for (std::size_t s = 0; s < girth.size(); ++s) {
    Shape& shape = fitted.segments[s].shape;
    shape.radius_start *= girth[s];
    shape.radius_end *= girth[s];
    shape.radii.x() *= girth[s];
    shape.radii.y() *= girth[s];
  }
  for (const std::string side : {"l_", "r_"}) {
    Shape& thigh = fitted.segments[model.points[index(side + "hip")].segment].shape;
    thigh.radius_end *= proportions.thigh_end_girth / proportions.leg_girth;
  }
  return fitted;
}

FitStance fitPoseAt(const BodyModel& model, const Eigen::VectorXd& placed) {
  if (!model.fit_pose)
    throw std::invalid_argument("body model '" + model.name +
                                "' has no fit_pose: the pose a subject stands in to be fitted");
  FitStance stance{model.stancePose(*model.fit_pose)};
  for (int d : model.segments.front().dofs) {
    const Dof& dof = model.dofs[d];
    const bool about_z =
        dof.type == DofType::kRotation && dof.axis.isApprox(Eigen::Vector3d::UnitZ());
    if (dof.type == DofType::kTranslation || about_z) stance.pose[d] = placed[d];
    if (about_z) stance.turn_dof = d;
  }
  return stance;
}

namespace {

// Scores candidate bodies on the frames: each pose refined from the best body's so far.
class BuildScorer {
 public:
  BuildScorer(const BodyModel& model, const Rig& rig,
              const std::vector<std::vector<SilhouetteMask>>& frames,
              std::vector<Eigen::VectorXd> poses, const LikelihoodParams& likelihood,
              int search_evaluations, std::function<bool()> should_stop)
      : rig_(rig),
        frames_(frames),
        poses_(std::move(poses)),
        likelihood_(likelihood),
        search_evaluations_(search_evaluations),
        should_stop_(std::move(should_stop)) {
    // Small steps: the tracked pose is near, and only what the build changes needs to move.
    for (std::size_t d = 0; d < model.dofs.size(); ++d) {
      if (!model.dofs[d].isFree()) continue;
      const bool metres = model.dofs[d].type == DofType::kTranslation;
      search_.add(static_cast<int>(d), metres ? 0.02 : 4 * M_PI / 180,
                  metres ? 0.002 : 0.5 * M_PI / 180);
    }
  }

  // The sum over the frames of the refined poses' log-likelihoods with `body`; its refined poses
  // into *refined.
  double score(const BodyModel& body, std::vector<Eigen::VectorXd>* refined) {
    FullBodyEvaluator evaluator(body, rig_, likelihood_.points_per_circle, 1);
    double total = 0;
    refined->assign(poses_.begin(), poses_.end());
    for (std::size_t f = 0; f < frames_.size(); ++f) {
      if (should_stop_ && should_stop_()) throw BodyFitStopped();
      auto value_of = [&](const Eigen::VectorXd& q) {
        return logLikelihood(likelihood_, evaluator.evaluate(q, frames_[f], 0));
      };
      Eigen::VectorXd& q = (*refined)[f];
      double value = value_of(q);
      evaluations_ += 1 + coordinateSearch(body, value_of, search_, search_evaluations_, q, value);
      total += value;
    }
    return total;
  }
  // Later candidates start from these poses.
  void startFrom(std::vector<Eigen::VectorXd> poses) { poses_ = std::move(poses); }
  long evaluations() const { return evaluations_; }

 private:
  const Rig& rig_;
  const std::vector<std::vector<SilhouetteMask>>& frames_;
  std::vector<Eigen::VectorXd> poses_;
  LikelihoodParams likelihood_;
  int search_evaluations_;
  std::function<bool()> should_stop_;
  SearchDofs search_;
  long evaluations_ = 0;
};

}  // namespace

BodyFit fitBodyToSubject(const BodyModel& model, const Rig& rig,
                         const std::vector<std::vector<SilhouetteMask>>& frames,
                         const std::vector<Eigen::VectorXd>& poses,
                         const LikelihoodParams& likelihood, const BodyFitOptions& options) {
  if (frames.empty() || frames.size() != poses.size())
    throw std::invalid_argument("fitting the body needs one tracked pose per frame, got " +
                                std::to_string(frames.size()) + " frames and " +
                                std::to_string(poses.size()) + " poses");
  for (const std::vector<SilhouetteMask>& masks : frames)
    if (masks.size() != rig.size())
      throw std::invalid_argument("a frame has " + std::to_string(masks.size()) +
                                  " silhouettes for " + std::to_string(rig.size()) + " cameras");
  if (!(options.scale_step > 0) || !(options.min_scale > 0) ||
      options.max_scale < options.min_scale)
    throw std::invalid_argument(
        "body scale candidates: expected 0 < min_scale <= max_scale and a positive step");
  if (!(options.min_factor > 0) || !(options.max_factor >= options.min_factor) ||
      !(options.max_thigh_end_girth >= options.min_factor) || !(options.proportion_step > 0) ||
      !(options.thigh_end_step > 0) || !(options.finest_step > 0))
    throw std::invalid_argument(
        "body proportions: expected 0 < min_factor <= max_factor and max_thigh_end_girth, and "
        "positive steps");

  BodyFit fit;
  BuildScorer scorer(model, rig, frames, poses, likelihood, options.search_evaluations,
                     options.should_stop);
  auto uniform = [](double factor) {
    BodyProportions p;
    for (int k = 0; k < BodyProportions::kCount; ++k) p[k] = factor;
    return p;
  };
  const int candidates = static_cast<int>(std::floor(
                             (options.max_scale - options.min_scale) / options.scale_step + 1e-9)) +
                         1;
  fit.log_likelihood = -INFINITY;
  for (int k = 0; k < candidates; ++k) {
    const double scale = options.min_scale + k * options.scale_step;
    std::vector<Eigen::VectorXd> refined;
    const double value = scorer.score(proportionedBodyModel(model, uniform(scale)), &refined);
    fit.scale_log_likelihoods.push_back(value);
    if (value > fit.log_likelihood) {
      fit.log_likelihood = value;
      fit.scale = scale;
      fit.poses = std::move(refined);
    }
  }
  fit.proportions = uniform(fit.scale);
  scorer.startFrom(fit.poses);

  std::vector<double> first_step(BodyProportions::kCount, options.proportion_step);
  first_step[BodyProportions::kThighEndGirth] = options.thigh_end_step;
  std::vector<double> step = first_step;
  for (int round = 0; round < options.proportion_rounds; ++round) {
    for (int k = 0; k < BodyProportions::kCount; ++k) {
      const double max_factor =
          k == BodyProportions::kThighEndGirth ? options.max_thigh_end_girth : options.max_factor;
      // Each proportion until its step is below the finest, before the next.
      while (step[k] >= options.finest_step) {
        bool improved = false;
        for (double sign : {1.0, -1.0}) {
          BodyProportions tried = fit.proportions;
          tried[k] = std::clamp(tried[k] + sign * step[k], options.min_factor, max_factor);
          if (tried[k] == fit.proportions[k]) continue;
          std::vector<Eigen::VectorXd> refined;
          const double value = scorer.score(proportionedBodyModel(model, tried), &refined);
          if (value > fit.log_likelihood) {
            fit.proportions = tried;
            fit.log_likelihood = value;
            fit.poses = std::move(refined);
            scorer.startFrom(fit.poses);
            improved = true;
            break;
          }
        }
        if (!improved) step[k] *= 0.5;
      }
      step[k] = first_step[k] / 2;  // the next round looks closer
    }
  }
  fit.evaluations = scorer.evaluations();
  return fit;
}

std::optional<BodyFit> fitBodyInPose(const BodyModel& model, const Rig& rig,
                                     const std::vector<std::vector<SilhouetteMask>>& frames,
                                     const LikelihoodParams& likelihood,
                                     const BodyFitOptions& options, std::string* why_not) {
  if (!model.fit_pose)
    throw std::invalid_argument("body model '" + model.name +
                                "' has no fit_pose: the pose a subject stands in to be fitted");
  if (frames.empty()) throw std::invalid_argument("fitting the body needs at least one frame set");
  // Found in each frame set on its own: the subject may turn between them.
  const Eigen::VectorXd pose = model.stancePose(*model.fit_pose);
  std::vector<std::vector<SilhouetteMask>> seen;
  std::vector<Eigen::VectorXd> poses;
  long evaluations = 0;
  std::string why;
  for (const std::vector<SilhouetteMask>& masks : frames) {
    if (options.should_stop && options.should_stop()) throw BodyFitStopped();
    const std::vector<Acquisition> found =
        acquireSubject(model, rig, masks, {pose}, likelihood, AcquireOptions{}, &why);
    if (found.empty()) continue;
    seen.push_back(masks);
    poses.push_back(found.front().q);
    evaluations += found.front().evaluations;
  }
  if (seen.empty()) {
    if (why_not) *why_not = why;
    return std::nullopt;
  }
  BodyFit fit = fitBodyToSubject(model, rig, seen, poses, likelihood, options);
  fit.evaluations += evaluations;
  return fit;
}

}  // namespace mocap
