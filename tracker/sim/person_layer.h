// A rendered person as a layer to composite over a background: its mask, shaded colours and depth
// in one camera. What a person renderer hands the colour scenes (test_scene.h, the fake driver's).
#pragma once

#include <optional>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace mocap {

struct PersonLayer {
  cv::Mat mask;    // CV_8UC1, 255 where the person is, 0 elsewhere
  cv::Mat colour;  // CV_8UC3 BGR, the lit person where mask is set, 0 elsewhere
  cv::Mat depth;  // CV_32FC1, camera depth (metres) where mask is set, +inf elsewhere; may be empty
  // A world point on the front of the chest (where a scene may put a patch), if the person has one.
  std::optional<Eigen::Vector3d> chest;
};

}  // namespace mocap
