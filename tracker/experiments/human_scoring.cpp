// Scoring of the human experiment (see human_scoring.h), and the silhouette defects and lost-frame
// causes of human_experiment.h.
#include "tracker/experiments/human_scoring.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "tracker/experiments/human_experiment.h"

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

}  // namespace mocap
