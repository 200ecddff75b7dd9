// Acquisition: silhouette centroid rays triangulated, the stance placed there at each heading, and
// the best headings searched locally on the full-body likelihood.
#include "tracker/search/acquire.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "tracker/likelihood/full_body.h"
#include "tracker/model/kinematics.h"
#include "tracker/search/pose_search.h"

namespace mocap {
namespace {

// The root's DOFs that place and turn the body: translations along world X, Y, Z (Z optional)
// and the rotation about Z. -1 where absent.
struct RootDofs {
  int x = -1, y = -1, z = -1, yaw = -1;
};

RootDofs findRootDofs(const BodyModel& model) {
  RootDofs root;
  if (model.segments.empty()) return root;
  for (int d : model.segments[0].dofs) {
    const Dof& dof = model.dofs[d];
    if (!dof.isFree()) continue;
    const Eigen::Vector3d& a = dof.axis;
    if (dof.type == DofType::kTranslation) {
      if (a.isApprox(Eigen::Vector3d::UnitX()) && root.x < 0) root.x = d;
      if (a.isApprox(Eigen::Vector3d::UnitY()) && root.y < 0) root.y = d;
      if (a.isApprox(Eigen::Vector3d::UnitZ()) && root.z < 0) root.z = d;
    } else if (a.isApprox(Eigen::Vector3d::UnitZ()) && root.yaw < 0 && root.x >= 0 && root.y >= 0) {
      // Only a rotation after the translations turns the body about its own vertical.
      root.yaw = d;
    }
  }
  return root;
}

// The centroid of the body's volume (each shape a solid of uniform density), world frame.
Eigen::Vector3d bodyCentroid(const BodyModel& model, const KinematicsData& kinematics) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double volume = 0;
  for (std::size_t s = 0; s < model.segments.size(); ++s) {
    const Shape& shape = model.segments[s].shape;
    double v = 0;
    Eigen::Vector3d local;
    if (shape.type == ShapeType::kEllipsoid) {
      v = 4.0 / 3.0 * M_PI * shape.radii.prod();
      local = shape.center;
    } else if (shape.type == ShapeType::kTruncatedCone) {
      const double a = shape.radius_start, b = shape.radius_end;
      const double sq = a * a + a * b + b * b;
      v = M_PI * shape.length * sq / 3.0;
      // The frustum's centroid from its wide or narrow end, along the axis.
      local = shape.axis.normalized() * (shape.length * (a * a + 2 * a * b + 3 * b * b) / (4 * sq));
    } else {
      continue;
    }
    sum += v * (kinematics.world[s] * local);
    volume += v;
  }
  return volume > 0 ? Eigen::Vector3d(sum / volume) : kinematics.world[0].translation();
}

double wrapInto(double angle, const Dof& dof) {
  // Turns by whole turns into the DOF's range where one fits (the human's yaw spans ±360°).
  while (angle > dof.max && angle - 2 * M_PI >= dof.min) angle -= 2 * M_PI;
  while (angle < dof.min && angle + 2 * M_PI <= dof.max) angle += 2 * M_PI;
  return std::clamp(angle, dof.min, dof.max);
}

void checkUncross(const AcquireOptions& options) {
  if (!(options.uncross >= 0 && std::isfinite(options.uncross)))
    throw std::invalid_argument("acquisition: the crossed feet's weight (uncross) must be >= 0");
}

void checkAcquireArguments(const BodyModel& model, const Rig& rig,
                           const std::vector<SilhouetteMask>& masks,
                           const std::vector<Eigen::VectorXd>& stances,
                           const AcquireOptions& options) {
  if (!canAcquire(model)) throw std::invalid_argument("acquisition: " + whyCannotAcquire(model));
  if (masks.size() != rig.size())
    throw std::invalid_argument("acquisition: expected one silhouette per camera");
  if (stances.empty()) throw std::invalid_argument("acquisition: no stance to try");
  for (const Eigen::VectorXd& stance : stances)
    if (stance.size() != static_cast<long>(model.dofs.size()))
      throw std::invalid_argument("acquisition: a stance has the wrong number of DOFs");
  if (options.headings < 1 || options.searched_headings < 1 || options.search_evaluations < 0)
    throw std::invalid_argument("acquisition: headings and searched headings must be >= 1");
  checkUncross(options);
}

// The point nearest every silhouette's centroid ray. Nothing, and the reason in `why`, when fewer
// than two cameras see the subject or their rays are too nearly parallel to meet.
std::optional<Eigen::Vector3d> triangulateSilhouettes(const Rig& rig,
                                                      const std::vector<SilhouetteMask>& masks,
                                                      long min_silhouette_pixels,
                                                      std::string& why) {
  // Least squares: sum (I - d d^T)(P - C) = 0.
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  int seeing = 0;
  std::string seen;
  for (std::size_t c = 0; c < rig.size(); ++c) {
    if (masks[c].width() != rig[c].width || masks[c].height() != rig[c].height)
      throw std::invalid_argument("acquisition: camera " + std::to_string(c) +
                                  "'s silhouette differs in size from the camera");
    const cv::Moments m = cv::moments(masks[c].toMat(), true);
    seen += (c ? ", " : "") + std::to_string(static_cast<long>(m.m00));
    if (m.m00 < static_cast<double>(min_silhouette_pixels)) continue;
    const Eigen::Vector3d d = rig[c].backProject(Eigen::Vector2d(m.m10 / m.m00, m.m01 / m.m00));
    const Eigen::Matrix3d away = Eigen::Matrix3d::Identity() - d * d.transpose();
    normal += away;
    rhs += away * rig[c].center();
    ++seeing;
  }
  if (seeing < 2) {
    why = "no subject: " + std::to_string(seeing) + " camera(s) see at least " +
          std::to_string(min_silhouette_pixels) +
          " silhouette pixels, two are needed (pixels per camera: " + seen + ")";
    return std::nullopt;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(normal);
  if (eigen.eigenvalues()(0) < 1e-3) {
    why =
        "the cameras that see the subject look along nearly the same line; its distance cannot "
        "be told";
    return std::nullopt;
  }
  return Eigen::Vector3d(normal.ldlt().solve(rhs));
}

struct Start {
  Eigen::VectorXd q;
  double value;
};

// The best `count` starts whose headings lie at least 60 degrees apart: a standing body's
// silhouettes are nearly the same facing either way, so the one turned round is kept to be told
// apart by its limbs.
std::vector<Start> headingsApart(std::vector<Start> scanned, int count, int yaw) {
  std::stable_sort(scanned.begin(), scanned.end(),
                   [](const Start& a, const Start& b) { return a.value > b.value; });
  std::vector<Start> starts;
  for (Start& candidate : scanned) {
    if (static_cast<int>(starts.size()) == count) break;
    const bool apart = std::all_of(starts.begin(), starts.end(), [&](const Start& taken) {
      return std::abs(std::remainder(candidate.q[yaw] - taken.q[yaw], 2 * M_PI)) >= M_PI / 3 - 1e-9;
    });
    if (apart) starts.push_back(std::move(candidate));
  }
  return starts;
}

// Searches that ended facing the same way (within 45 degrees) found one hypothesis: the best of
// them stands for it. Best first.
std::vector<Acquisition> distinctHypotheses(std::vector<Acquisition> found, int yaw,
                                            int evaluations) {
  std::stable_sort(found.begin(), found.end(), [](const Acquisition& a, const Acquisition& b) {
    return a.log_likelihood > b.log_likelihood;
  });
  std::vector<Acquisition> distinct;
  for (Acquisition& a : found) {
    const bool apart = std::all_of(distinct.begin(), distinct.end(), [&](const Acquisition& kept) {
      return std::abs(std::remainder(a.q[yaw] - kept.q[yaw], 2 * M_PI)) >= M_PI / 4;
    });
    if (!apart) continue;
    a.evaluations = evaluations;
    distinct.push_back(std::move(a));
  }
  return distinct;
}

SearchDofs rootPlacementSearch(const RootDofs& root, int headings) {
  SearchDofs search;
  search.add(root.x, 0.1, 0.005);
  search.add(root.y, 0.1, 0.005);
  search.add(root.yaw, M_PI / headings / 2, M_PI / 360);
  if (root.z >= 0) search.add(root.z, 0.05, 0.005);
  return search;
}

SearchDofs everyFreeDofSearch(const BodyModel& model) {
  SearchDofs search;
  for (std::size_t d = 0; d < model.dofs.size(); ++d) {
    if (!model.dofs[d].isFree()) continue;
    const bool metres = model.dofs[d].type == DofType::kTranslation;
    search.add(static_cast<int>(d), metres ? 0.05 : M_PI / 12, metres ? 0.005 : M_PI / 180);
  }
  return search;
}

}  // namespace

bool canAcquire(const BodyModel& model) {
  const RootDofs root = findRootDofs(model);
  return root.x >= 0 && root.y >= 0 && root.yaw >= 0;
}

std::string whyCannotAcquire(const BodyModel& model) {
  return "the body model '" + model.name +
         "' has no free root translations along X and Y and rotation about Z to place it by";
}

std::vector<Acquisition> acquireSubject(const BodyModel& model, const Rig& rig,
                                        const std::vector<SilhouetteMask>& masks,
                                        const std::vector<Eigen::VectorXd>& stances,
                                        const LikelihoodParams& likelihood,
                                        const AcquireOptions& options, std::string* why_not) {
  checkAcquireArguments(model, rig, masks, stances, options);
  const RootDofs root = findRootDofs(model);
  std::string why;
  const std::optional<Eigen::Vector3d> triangulated =
      triangulateSilhouettes(rig, masks, options.min_silhouette_pixels, why);
  if (!triangulated) {
    if (why_not) *why_not = why;
    return {};
  }
  const Eigen::Vector3d centre = *triangulated;

  FullBodyEvaluator evaluator(model, rig, likelihood.points_per_circle, 1);
  KinematicsData kinematics(model);
  const CrossedLegs crossed = findCrossedLegs(model, options.uncross);
  int evaluations = 0;
  auto score = [&](const Eigen::VectorXd& q) {
    ++evaluations;
    return logLikelihood(likelihood, evaluator.evaluate(q, masks, 0)) -
           crossed.cost(model, kinematics, q);
  };
  // A stance at heading h, moved so its centroid is the triangulated point.
  auto placed = [&](const Eigen::VectorXd& stance, double heading) {
    Eigen::VectorXd q = stance;
    q[root.yaw] = wrapInto(heading, model.dofs[root.yaw]);
    forwardKinematics(model, kinematics, q);
    const Eigen::Vector3d shift = centre - bodyCentroid(model, kinematics);
    q[root.x] += shift.x();
    q[root.y] += shift.y();
    if (root.z >= 0) q[root.z] += shift.z();
    clampToLimits(model, q);
    return q;
  };

  std::vector<Start> scanned;
  for (int h = 0; h < options.headings; ++h) {
    Start best{{}, -INFINITY};
    for (const Eigen::VectorXd& stance : stances) {
      Eigen::VectorXd q = placed(stance, 2 * M_PI * h / options.headings);
      const double value = score(q);
      if (value > best.value) best = {std::move(q), value};
    }
    scanned.push_back(std::move(best));
  }
  std::vector<Start> starts =
      headingsApart(std::move(scanned), options.searched_headings, root.yaw);

  // First the root's place and heading, then every free DOF: the limbs, fitted, tell the heading
  // the stance alone could not (a knee bends one way only).
  const SearchDofs root_search = rootPlacementSearch(root, options.headings);
  const SearchDofs all_search = everyFreeDofSearch(model);
  std::vector<Acquisition> found;
  for (Start& start : starts) {
    coordinateSearch(model, score, root_search, options.search_evaluations, start.q, start.value);
    coordinateSearch(model, score, all_search, options.fit_evaluations, start.q, start.value);
    found.push_back({std::move(start.q), start.value, centre, 0});
  }
  return distinctHypotheses(std::move(found), root.yaw, evaluations);
}

double silhouetteFit(const PixelCounts& counts, const std::vector<SilhouetteMask>& masks) {
  long silhouette = 0;
  for (const SilhouetteMask& mask : masks) silhouette += mask.total();
  if (silhouette == 0) return -1;
  const double fit =
      static_cast<double>(counts.matched - counts.outside) / static_cast<double>(silhouette);
  return std::max(fit, -1.0);
}

std::vector<Eigen::VectorXd> acquisitionStances(const BodyModel& model) {
  std::vector<Eigen::VectorXd> stances = {model.neutralPose()};
  for (const Stance& stance : model.stances) stances.push_back(model.stancePose(stance));
  return stances;
}

AcquiringFilter::AcquiringFilter(const BodyModel& model, const Rig& rig,
                                 std::vector<Eigen::VectorXd> stances,
                                 const LikelihoodParams& likelihood, FilterFactory make_filter,
                                 const AcquiringOptions& options)
    : model_(model),
      rig_(rig),
      stances_(std::move(stances)),
      likelihood_(likelihood),
      make_filter_(std::move(make_filter)),
      options_(options),
      scorer_(model, rig, likelihood.points_per_circle, 1),
      crossing_(model) {
  if (!canAcquire(model)) throw std::invalid_argument("acquisition: " + whyCannotAcquire(model));
  checkUncross(options.search);
  crossed_ = findCrossedLegs(model, options.search.uncross);
  if (options.trial_frames < 1)
    throw std::invalid_argument("acquisition: trial frames must be >= 1");
  if (!(options.lost_below >= 0 && options.lost_below < 1))
    throw std::invalid_argument("acquisition: the lost fit ratio must be in [0, 1)");
  if (options.lost_after < 1)
    throw std::invalid_argument("acquisition: frames before the tracker is lost must be >= 1");
  if (options.challenge_every < 0)
    throw std::invalid_argument("acquisition: frames between challenges must be >= 0");
  if (!(options.trial_drop_margin >= 0))
    throw std::invalid_argument("acquisition: the trial's drop margin must be >= 0");
}

std::string AcquiringFilter::name() const {
  return hypotheses_.empty() ? "acquiring" : hypotheses_.front().filter->name();
}

AcquiringFilter::Hypothesis AcquiringFilter::newHypothesis(const Eigen::VectorXd& q0,
                                                           std::optional<double> entry) {
  Hypothesis h{make_filter_(), 0, entry};
  h.filter->reset(q0);
  return h;
}

void AcquiringFilter::reset(const Eigen::VectorXd& q0) {
  challenge_ = {};
  hypotheses_.clear();
  hypotheses_.push_back(newHypothesis(q0));
  searching_ = false;
  trial_frames_left_ = 0;
  steps_ = 0;
  recent_fits_.clear();
  low_fit_frames_ = 0;
}

void AcquiringFilter::reacquire() {
  challenge_ = {};
  hypotheses_.clear();
  searching_ = true;
  trial_frames_left_ = 0;
}

void AcquiringFilter::setYield(std::function<bool()> newer_frame_waiting) {
  yield_ = std::move(newer_frame_waiting);  // passed on to the hypotheses at each step
}

FrameEstimate AcquiringFilter::step(const std::vector<SilhouetteMask>& masks) {
  long acquisition_evaluations = 0;
  ++steps_;
  if (searching_) {
    const std::vector<Acquisition> found =
        acquireSubject(model_, rig_, masks, stances_, likelihood_, options_.search, &last_failure_);
    if (found.empty()) {
      FrameEstimate none;
      none.q = stances_.front();
      none.found = false;
      return none;
    }
    last_failure_.clear();
    ++acquisitions_;
    acquisition_evaluations = found.front().evaluations;
    // A lost filter stays among the hypotheses (first, so it wins ties).
    for (Hypothesis& h : hypotheses_) h.score = 0;
    for (const Acquisition& a : found) hypotheses_.push_back(newHypothesis(a.q, a.log_likelihood));
    trial_frames_left_ = hypotheses_.size() > 1 ? options_.trial_frames : 0;
    // The loss rule learns its level anew after a loss, not while a track goes on.
    recent_fits_.clear();
    low_fit_frames_ = 0;
    searching_ = false;
  }

  // Each hypothesis tracks the frame and is scored on it; the one ahead so far is the estimate.
  // Once one is left, the scoring is only the fit's.
  FrameEstimate ahead;
  PixelCounts ahead_counts;
  double best = -INFINITY;
  long evaluations = 0, renders = 0;
  bool cut_short = false;
  // A challenge found on the previous frame joins a trial on this one.
  const bool joining = challenge_.valid();
  if (joining) hypotheses_.front().score = 0;
  // Live, a step gives way when the next frame set waits; in a trial that would cut the later
  // hypotheses' searches short and not the first's, so the trial would pick by timing. Competing
  // hypotheses search in full (the flow limiter drops sets meanwhile); a lone track gives way.
  const bool trial = hypotheses_.size() > 1 || joining;
  const double margin = trial ? options_.trial_drop_margin : 0;
  // A challenge found on the previous frame: its starts that pass the gate on that frame's scores
  // (the track's estimate and the best start's), each to track this frame as the track does, from
  // its pose of then; concurrently with the track if asked.
  std::vector<Hypothesis> rivals;
  std::vector<std::future<FrameEstimate>> rival_steps;
  bool challenge_found = false;
  if (joining) {
    Challenge challenge = challenge_.get();
    last_failure_ = challenge.why_not;
    challenge_found = !challenge.found.empty();
    if (challenge_found) {
      ++acquisitions_;
      acquisition_evaluations = challenge.found.front().evaluations;
      const double bar = std::max(challenge.track_score, challenge.found.front().log_likelihood);
      for (const Acquisition& a : challenge.found)
        if (!(margin > 0 && a.log_likelihood < bar - margin)) rivals.push_back(newHypothesis(a.q));
    }
    for (Hypothesis& h : rivals) {
      h.filter->setYield({});
      if (options_.concurrent_rivals)
        rival_steps.push_back(std::async(
            std::launch::async, [&masks, filter = h.filter.get()] { return filter->step(masks); }));
    }
  }
  auto score = [&](Hypothesis& h, FrameEstimate e) {
    const PixelCounts counts = scorer_.evaluate(e.q, masks, 0);
    h.score += logLikelihood(likelihood_, counts) - crossed_.cost(model_, crossing_, e.q);
    evaluations += e.evaluations + 1;
    renders += e.segment_renders + scorer_.drawnSegments();
    cut_short = cut_short || e.cut_short;
    if (h.score > best) {
      best = h.score;
      ahead = std::move(e);
      ahead_counts = counts;
    }
  };
  auto track = [&](Hypothesis& h) {
    h.filter->setYield(trial ? std::function<bool()>() : yield_);
    score(h, h.filter->step(masks));
  };
  // Hypotheses just found have their acquisition's fit of this frame as a first score: one already
  // `margin` behind the best does not track it (the track, first, has been scored by then).
  double best_entry = -INFINITY;
  for (const Hypothesis& h : hypotheses_)
    best_entry = std::max(best_entry, h.entry.value_or(-INFINITY));
  for (auto it = hypotheses_.begin(); it != hypotheses_.end();) {
    if (margin > 0 && it->entry && *it->entry < std::max(best, best_entry) - margin) {
      it = hypotheses_.erase(it);
      continue;
    }
    it->entry.reset();
    track(*it);
    ++it;
  }
  // Scored after the track, in the challenge's order, however they were stepped.
  for (std::size_t r = 0; r < rivals.size(); ++r) {
    hypotheses_.push_back(std::move(rivals[r]));
    Hypothesis& h = hypotheses_.back();
    score(h, r < rival_steps.size() ? rival_steps[r].get() : h.filter->step(masks));
  }
  if (challenge_found) trial_frames_left_ = hypotheses_.size() > 1 ? options_.trial_frames : 0;
  ahead.evaluations = evaluations + acquisition_evaluations;
  ahead.segment_renders = renders;
  ahead.cut_short = cut_short;
  ahead.silhouette_fit = silhouetteFit(ahead_counts, masks);
  if (margin > 0) {
    // Erased in place, so the track (first) stays first and keeps winning ties.
    std::erase_if(hypotheses_, [&](const Hypothesis& h) { return h.score < best - margin; });
    if (hypotheses_.size() == 1) trial_frames_left_ = 0;
  }
  // Lost (in a trial too): this estimate is still given, and the next step acquires again with
  // the filter ahead kept.
  const bool lost = lostAfter(ahead.silhouette_fit);
  if ((trial_frames_left_ > 0 && --trial_frames_left_ == 0) || lost) {
    auto winner = std::max_element(
        hypotheses_.begin(), hypotheses_.end(),
        [](const Hypothesis& a, const Hypothesis& b) { return a.score < b.score; });
    Hypothesis kept = std::move(*winner);
    hypotheses_.clear();
    hypotheses_.push_back(std::move(kept));
    trial_frames_left_ = 0;
  }
  if (lost) {
    ++losses_;
    searching_ = true;
  } else if (options_.challenge_every > 0 && steps_ % options_.challenge_every == 0 &&
             hypotheses_.size() == 1) {
    // The subject is found again on this frame's masks beside the track (another thread: live,
    // while the tracker waits for the next set), and the starts join the next frame's trial.
    challenge_ = std::async(std::launch::async,
                            [this, masks,
                             track_score = logLikelihood(likelihood_, ahead_counts) -
                                           crossed_.cost(model_, crossing_, ahead.q)] {
                              Challenge c;
                              c.found = acquireSubject(model_, rig_, masks, stances_, likelihood_,
                                                       options_.search, &c.why_not);
                              c.track_score = track_score;
                              return c;
                            });
  }
  return ahead;
}

bool AcquiringFilter::lostAfter(double fit) {
  constexpr std::size_t kWindow = 50, kWarmUp = 25;
  bool low = fit <= 0;  // explains no more silhouette than it draws off it: nothing is tracked
  if (!low && options_.lost_below > 0 && recent_fits_.size() >= kWarmUp) {
    std::vector<double> sorted = recent_fits_;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    low = fit < options_.lost_below * sorted[sorted.size() / 2];
  }
  if (low) return ++low_fit_frames_ >= options_.lost_after;
  low_fit_frames_ = 0;
  recent_fits_.push_back(fit);
  if (recent_fits_.size() > kWindow) recent_fits_.erase(recent_fits_.begin());
  return false;
}

}  // namespace mocap
