// Edge distances near a silhouette: Canny on the blurred image, kept near the person, with the
// silhouette's boundary, then a distance transform, all within the silhouette's box.
#include "tracker/likelihood/edge_map.h"

#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace mocap {

cv::Mat edgeDistance(const cv::Mat& image, const cv::Mat& silhouette,
                     const EdgeMapOptions& options) {
  if ((image.type() != CV_8UC3 && image.type() != CV_8UC1) || silhouette.type() != CV_8UC1 ||
      image.size() != silhouette.size())
    throw std::invalid_argument("edge map: expected an 8-bit image and a silhouette of its size");
  cv::Mat distance(image.size(), CV_8UC1, cv::Scalar(options.clamp));
  const cv::Rect person = cv::boundingRect(silhouette);
  if (person.empty()) return distance;
  const int margin = 2 * options.clamp + 4;
  const cv::Rect box = cv::Rect(person.x - margin, person.y - margin, person.width + 2 * margin,
                                person.height + 2 * margin) &
                       cv::Rect(cv::Point(0, 0), image.size());
  cv::Mat gray;
  if (image.channels() == 3)
    cv::cvtColor(image(box), gray, cv::COLOR_BGR2GRAY);
  else
    gray = image(box).clone();
  cv::GaussianBlur(gray, gray, cv::Size(), options.blur_sigma);
  cv::Mat edges;
  cv::Canny(gray, edges, options.low_threshold, options.high_threshold, 3, true);
  const cv::Mat kernel = cv::getStructuringElement(
      cv::MORPH_ELLIPSE, cv::Size(2 * options.clamp + 1, 2 * options.clamp + 1));
  cv::Mat near, inner;
  const cv::Mat person_box = silhouette(box) > 0;
  cv::dilate(person_box, near, kernel);
  edges &= near;
  cv::erode(person_box, inner, cv::Mat());
  edges |= person_box & ~inner;
  cv::Mat far;
  cv::distanceTransform(~edges, far, cv::DIST_L2, 3);
  cv::min(far, options.clamp, far);
  far.convertTo(distance(box), CV_8U);
  return distance;
}

}  // namespace mocap
