// Unexplained silhouette blobs: the mask minus the footprints, opened, then connected components,
// all within the pose's box grown by a quarter on each side, so a person-sized pose costs a
// person-sized image.
#include "tracker/likelihood/unexplained.h"

#include <algorithm>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace mocap {

std::vector<UnexplainedBlob> unexplainedBlobs(const SilhouetteMask& mask,
                                              const Footprint* footprints, int count, long min_area,
                                              int opening) {
  if (opening < 1 || opening % 2 == 0)
    throw std::invalid_argument("unexplained blobs: the opening must be an odd size >= 1");
  std::vector<UnexplainedBlob> blobs;
  cv::Rect pose;
  for (int k = 0; k < count; ++k)
    if (!footprints[k].empty())
      pose |=
          cv::Rect(footprints[k].xmin, footprints[k].y0, footprints[k].xmax - footprints[k].xmin,
                   footprints[k].y1 - footprints[k].y0);
  if (pose.empty()) return blobs;
  const cv::Rect box =
      cv::Rect(pose.x - pose.width / 4, pose.y - pose.height / 4, pose.width + 2 * (pose.width / 4),
               pose.height + 2 * (pose.height / 4)) &
      cv::Rect(0, 0, mask.width(), mask.height());
  cv::Mat left = mask.toMat(box);
  for (int k = 0; k < count; ++k) {
    const Footprint& f = footprints[k];
    for (int y = std::max(f.y0, box.y); y < std::min(f.y1, box.y + box.height); ++y) {
      const RowSpan& span = f.spans[y - f.y0];
      const int x0 = std::clamp(span.x0 - box.x, 0, box.width);
      const int x1 = std::clamp(span.x1 - box.x, x0, box.width);
      std::fill(left.ptr<uint8_t>(y - box.y) + x0, left.ptr<uint8_t>(y - box.y) + x1, 0);
    }
  }
  if (opening > 1)
    cv::morphologyEx(left, left, cv::MORPH_OPEN,
                     cv::getStructuringElement(cv::MORPH_RECT, cv::Size(opening, opening)),
                     cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(left, labels, stats, centroids, 8, CV_32S);
  for (int i = 1; i < n; ++i) {
    const long area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (area < min_area) continue;
    blobs.push_back(
        {Eigen::Vector2d(centroids.at<double>(i, 0) + box.x, centroids.at<double>(i, 1) + box.y),
         area});
  }
  std::stable_sort(
      blobs.begin(), blobs.end(),
      [](const UnexplainedBlob& a, const UnexplainedBlob& b) { return a.area > b.area; });
  return blobs;
}

}  // namespace mocap
