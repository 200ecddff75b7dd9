// The image edges a person's limbs make, for the likelihood's edge term (LikelihoodParams::
// edge_weight): a silhouette says where the person is, not where a leg lies in front of the other
// or an arm across the chest; the image's edges inside it do.
#pragma once

#include <opencv2/core/mat.hpp>

namespace mocap {

struct EdgeMapOptions {
  double blur_sigma = 1.2;                         // Gaussian, against the sensor's noise
  double low_threshold = 20, high_threshold = 60;  // Canny's, on the blurred gray image
  int clamp = 8;  // distances beyond are this: a far edge is no evidence either way
};

// Each pixel's distance (pixels, up to options.clamp) to the nearest edge of `image` (CV_8UC3 BGR
// or CV_8UC1) within options.clamp of `silhouette` (CV_8UC1, non-zero = person), or of the
// silhouette's own boundary. CV_8UC1 of the image's size. Throws std::invalid_argument if the
// types or sizes do not fit.
cv::Mat edgeDistance(const cv::Mat& image, const cv::Mat& silhouette,
                     const EdgeMapOptions& options = {});

}  // namespace mocap
