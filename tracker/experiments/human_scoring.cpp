// Scoring of the human experiment (see human_scoring.h), and the silhouette defects and lost-frame
// causes of human_experiment.h.
#include "tracker/experiments/human_scoring.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "tracker/experiments/human_experiment.h"
#include "tracker/motion/retarget.h"
#include "tracker/search/acquire.h"

namespace mocap {

void corruptSilhouette(cv::Mat& mask, uint64_t seed, int frame, int camera) {
  const cv::Rect box = cv::boundingRect(mask);
  if (box.area() == 0) return;
  cv::RNG rng(seed * 1000003ULL + static_cast<uint64_t>(frame) * 101ULL +
              static_cast<uint64_t>(camera) + 1);
  // Ragged edges: every pixel within a pixel of the outline is decided by a coin.
  cv::Mat grown, shrunk, band, coin(mask.size(), CV_8UC1);
  cv::dilate(mask, grown, cv::Mat());
  cv::erode(mask, shrunk, cv::Mat());
  cv::bitwise_xor(grown, shrunk, band);
  rng.fill(coin, cv::RNG::UNIFORM, 0, 2);
  coin *= 255;
  coin.copyTo(mask, band);
  // Holes: a few small blobs inside the body go missing.
  for (int hole = 0; hole < 4; ++hole) {
    for (int attempt = 0; attempt < 30; ++attempt) {
      const cv::Point p(rng.uniform(box.x, box.x + box.width),
                        rng.uniform(box.y, box.y + box.height));
      if (!mask.at<uint8_t>(p)) continue;
      cv::circle(mask, p, rng.uniform(2, 7), cv::Scalar(0), cv::FILLED);
      break;
    }
  }
  // A shadow on the floor beside the feet, joined to them.
  const double h = box.height;
  const int side = rng.uniform(0, 2) ? 1 : -1;
  const cv::Point centre(static_cast<int>(box.x + 0.5 * box.width + side * 0.25 * h),
                         static_cast<int>(box.y + box.height - 0.03 * h));
  cv::ellipse(mask, centre, cv::Size(static_cast<int>(0.28 * h), static_cast<int>(0.045 * h)), 0, 0,
              360, cv::Scalar(255), cv::FILLED);
}

std::vector<Limb> limbsOf(const BodyModel& model) {
  const std::pair<const char*, std::vector<const char*>> kLimbs[] = {
      {"left_arm", {"l_shoulder", "l_elbow", "l_wrist", "l_hand"}},
      {"right_arm", {"r_shoulder", "r_elbow", "r_wrist", "r_hand"}},
      {"left_leg", {"l_hip", "l_knee", "l_ankle", "l_toe"}},
      {"right_leg", {"r_hip", "r_knee", "r_ankle", "r_toe"}}};
  std::vector<Limb> limbs;
  for (const auto& [name, points] : kLimbs) {
    Limb limb{name, {}};
    for (const char* point : points)
      if (const int p = model.pointIndex(point); p >= 0) limb.points.push_back(p);
    if (!limb.points.empty()) limbs.push_back(std::move(limb));
  }
  return limbs;
}

double legsSwappedError(const Limb& left, const Limb& right,
                        const std::vector<Eigen::Vector3d>& truth,
                        const std::vector<Eigen::Vector3d>& estimate) {
  if (left.points.size() != right.points.size()) return NAN;
  double sum = 0;
  for (std::size_t i = 0; i < left.points.size(); ++i)
    sum += 1000 * ((estimate[left.points[i]] - truth[right.points[i]]).norm() +
                   (estimate[right.points[i]] - truth[left.points[i]]).norm());
  return sum / (2 * left.points.size());
}

int longestLoss(const std::vector<double>& frame_error) {
  int longest = 0, run = 0;
  for (double error : frame_error) {
    run = error > kLostMm ? run + 1 : 0;
    longest = std::max(longest, run);
  }
  return longest;
}

std::optional<int> firstLock(const std::vector<double>& frame_error) {
  const int n = static_cast<int>(frame_error.size());
  for (int i = 0; i < n; ++i) {
    const int end = std::min(n, i + kLockFrames);
    if (std::all_of(frame_error.begin() + i, frame_error.begin() + end,
                    [](double error) { return error <= kLostMm; }))
      return i;
  }
  return std::nullopt;
}

std::string lostFrameCause(double left_leg, double right_leg, double worst_arm,
                           double heading_error_deg, double legs_swapped) {
  if (legs_swapped < 0.25 * (left_leg + right_leg)) return "legs_swapped";
  if (std::abs(heading_error_deg) > 20) return "heading";
  if (std::max(left_leg, right_leg) > 100) return "legs";
  if (worst_arm > 100) return "arms";
  return "other";
}

HumanRunScore::HumanRunScore(const BodyModel& model, const BodyModel& tracked_body, const Rig& rig,
                             const LikelihoodParams& likelihood, bool score_floor,
                             const std::string& trace_path)
    : model_(model),
      tracked_body_(tracked_body),
      likelihood_(likelihood),
      score_floor_(score_floor),
      tracked_kin_(tracked_body),
      limbs_(limbsOf(model)),
      left_leg_(limbNamed("left_leg")),
      right_leg_(limbNamed("right_leg")),
      left_arm_(limbNamed("left_arm")),
      right_arm_(limbNamed("right_arm")),
      l_hip_(model.pointIndex("l_hip")),
      r_hip_(model.pointIndex("r_hip")),
      per_joint_(model.points.size(), 0.0),
      limb_error_(limbs_.size()) {
  if (trace_path.empty()) return;
  trace_.open(trace_path);
  if (!trace_) throw std::runtime_error("--trace: cannot write '" + trace_path + "'");
  trace_ << "frame,mpjpe_mm,truth_log_likelihood,estimate_log_likelihood,heading_error_deg";
  for (const Limb& limb : limbs_) trace_ << ',' << limb.name << "_mm";
  trace_ << ",legs_swapped_mm,silhouette_pixels,estimate_fit,found\n";
  truth_scorer_ = std::make_unique<FullBodyEvaluator>(model, rig, likelihood.points_per_circle, 1);
  estimate_scorer_ =
      std::make_unique<FullBodyEvaluator>(tracked_body, rig, likelihood.points_per_circle, 1);
}

int HumanRunScore::limbNamed(const char* name) const {
  for (std::size_t l = 0; l < limbs_.size(); ++l)
    if (std::string_view(limbs_[l].name) == name) return static_cast<int>(l);
  return -1;
}

double HumanRunScore::latestLimbError(int limb) const {
  return limb >= 0 ? limb_error_[limb].back() : 0.0;
}

// Heading: the direction of the hip axis (right hip to left hip) on the ground plane.
double HumanRunScore::headingErrorDeg(const std::vector<Eigen::Vector3d>& truth,
                                      const std::vector<Eigen::Vector3d>& estimate) const {
  if (l_hip_ < 0 || r_hip_ < 0) return 0.0;
  const auto heading = [&](const std::vector<Eigen::Vector3d>& points) {
    const Eigen::Vector3d axis = points[l_hip_] - points[r_hip_];
    return std::atan2(axis.y(), axis.x());
  };
  return std::remainder(heading(estimate) - heading(truth), 2 * M_PI) * 180 / M_PI;
}

void HumanRunScore::add(int frame, const Eigen::VectorXd& truth,
                        const std::vector<Eigen::Vector3d>& true_points,
                        const Eigen::VectorXd& estimate, bool found,
                        const std::vector<SilhouetteMask>& masks) {
  if (frames_.empty()) floor_pose_ = truth;
  frames_.push_back(frame);
  forwardKinematics(tracked_body_, tracked_kin_, estimate);
  const auto tracked_points = pointPositions(tracked_body_, tracked_kin_);
  double sum = 0;
  for (std::size_t p = 0; p < true_points.size(); ++p) {
    const double e = 1000 * (true_points[p] - tracked_points[p]).norm();
    per_joint_[p] += e;
    sum += e;
  }
  frame_error_.push_back(sum / true_points.size());
  if (score_floor_) scoreFloor(true_points);
  for (std::size_t l = 0; l < limbs_.size(); ++l) {
    double limb_sum = 0;
    for (int p : limbs_[l].points) limb_sum += 1000 * (true_points[p] - tracked_points[p]).norm();
    limb_error_[l].push_back(limb_sum / limbs_[l].points.size());
  }
  const double heading_error = headingErrorDeg(true_points, tracked_points);
  const double legs_swapped =
      left_leg_ >= 0 && right_leg_ >= 0
          ? legsSwappedError(limbs_[left_leg_], limbs_[right_leg_], true_points, tracked_points)
          : NAN;
  const bool lost = frame_error_.back() > kLostMm;
  if (lost)
    ++lost_causes_[lostFrameCause(latestLimbError(left_leg_), latestLimbError(right_leg_),
                                  std::max(latestLimbError(left_arm_), latestLimbError(right_arm_)),
                                  heading_error, legs_swapped)];
  if (truth_scorer_)
    writeTrace(frame, truth, estimate, found, masks, heading_error, legs_swapped, lost);
}

// The tracked body's pose nearest the true joints (warm-started, pulled toward nothing).
void HumanRunScore::scoreFloor(const std::vector<Eigen::Vector3d>& true_points) {
  IkOptions floor_ik;
  floor_ik.prior_weight = 0;
  floor_ik.respect_speed_limits = false;
  floor_pose_ = fitPoseToPoints(tracked_body_, true_points, floor_pose_, floor_pose_, floor_ik).q;
  forwardKinematics(tracked_body_, tracked_kin_, floor_pose_);
  const auto floor_points = pointPositions(tracked_body_, tracked_kin_);
  double floor_sum = 0;
  for (std::size_t p = 0; p < true_points.size(); ++p)
    floor_sum += 1000 * (true_points[p] - floor_points[p]).norm();
  body_floor_mm_ += floor_sum / true_points.size();
}

void HumanRunScore::writeTrace(int frame, const Eigen::VectorXd& truth,
                               const Eigen::VectorXd& estimate, bool found,
                               const std::vector<SilhouetteMask>& masks, double heading_error,
                               double legs_swapped, bool lost) {
  const double truth_score = logLikelihood(likelihood_, truth_scorer_->evaluate(truth, masks, 0));
  const PixelCounts estimate_counts = estimate_scorer_->evaluate(estimate, masks, 0);
  const double estimate_score = logLikelihood(likelihood_, estimate_counts);
  lost_truth_ahead_ += lost && truth_score > estimate_score + 20;
  trace_ << frame << ',' << frame_error_.back() << ',' << truth_score << ',' << estimate_score
         << ',' << heading_error;
  for (const auto& error : limb_error_) trace_ << ',' << error.back();
  long silhouette_pixels = 0;
  for (const SilhouetteMask& mask : masks) silhouette_pixels += mask.total();
  trace_ << ',' << legs_swapped << ',' << silhouette_pixels << ','
         << silhouetteFit(estimate_counts, masks) << ',' << found << '\n';
}

std::optional<int> HumanRunScore::firstUnder50(const std::vector<double>& errors) const {
  for (std::size_t i = 0; i < errors.size(); ++i)
    if (errors[i] < 50.0) return frames_[i];
  return std::nullopt;
}

std::optional<int> HumanRunScore::recoveryFrame() const { return firstUnder50(frame_error_); }

std::optional<int> HumanRunScore::leftArmRecoveryFrame() const {
  return left_arm_ >= 0 ? firstUnder50(limb_error_[left_arm_]) : std::nullopt;
}

std::optional<int> HumanRunScore::firstLockFrame() const {
  const std::optional<int> lock = firstLock(frame_error_);
  return lock ? std::optional<int>(frames_[*lock]) : std::nullopt;
}

void HumanRunScore::summarize(nlohmann::json& out) const {
  const int scored = scoredFrames();
  nlohmann::json joints = nlohmann::json::object();
  for (std::size_t p = 0; p < per_joint_.size(); ++p)
    joints[model_.points[p].name] = per_joint_[p] / scored;
  double mpjpe = 0, worst = 0;
  int lost = 0;
  for (double error : frame_error_) {
    mpjpe += error;
    worst = std::max(worst, error);
    lost += error > kLostMm;
  }
  // Per limb: mean error and frames lost (limb error over 100 mm).
  nlohmann::json per_limb = nlohmann::json::object(), limb_lost = nlohmann::json::object();
  for (std::size_t l = 0; l < limbs_.size(); ++l) {
    double limb_sum = 0;
    int limb_lost_frames = 0;
    for (double error : limb_error_[l]) {
      limb_sum += error;
      limb_lost_frames += error > kLostMm;
    }
    per_limb[limbs_[l].name] = limb_sum / scored;
    limb_lost[limbs_[l].name] = limb_lost_frames;
  }
  out["mpjpe_mm"] = mpjpe / scored;
  out["per_joint_mm"] = joints;
  out["per_limb_mm"] = per_limb;
  out["limb_lost_frames"] = limb_lost;
  out["max_frame_mpjpe_mm"] = worst;
  out["lost_frames"] = lost;
  out["lost_frame_causes"] = lost_causes_;
  // Lost frames that are a failure of the search (the truth scores higher) rather than an
  // ambiguity of the silhouettes.
  if (truth_scorer_) out["lost_frames_truth_ahead"] = lost_truth_ahead_;
}

}  // namespace mocap
