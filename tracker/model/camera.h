// Calibrated pinhole camera with OpenCV's distortion model (k1, k2, p1, p2, k3), and rig files in
// OpenCV FileStorage YAML, the format OpenCV's calibration tools write.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace mocap {

struct CameraModel {
  std::string name;
  int width = 780;
  int height = 580;
  double fx = 1000, fy = 1000, cx = 390, cy = 290;
  std::array<double, 5> distortion{};                      // k1, k2, p1, p2, k3
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // world -> camera
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   // world -> camera, metres

  // Nearest depth (metres, camera z) at which a point is still projected.
  static constexpr double kMinDepth = 1e-3;

  Eigen::Vector3d toCamera(const Eigen::Vector3d& world) const {
    return rotation * world + translation;
  }
  // Pixel coordinates of a point in the camera frame with z >= kMinDepth. OpenCV's convention:
  // the centre of the top-left pixel is (0, 0).
  Eigen::Vector2d projectCameraPoint(const Eigen::Vector3d& p) const;
  // Pixel coordinates of a world point; false if it is behind (or too near) the camera.
  bool project(const Eigen::Vector3d& world, Eigen::Vector2d& pixel) const;
  // Camera centre in world coordinates.
  Eigen::Vector3d center() const { return -rotation.transpose() * translation; }
  // The unit direction, in world coordinates, of the ray from the centre through `pixel`: the
  // inverse of project() (the distortion undone by fixed-point iteration, as OpenCV's
  // undistortPoints does).
  Eigen::Vector3d backProject(const Eigen::Vector2d& pixel) const;

  // A distortion-free camera at `eye` looking at `target`, image "up" as close to `up` as possible.
  static CameraModel lookAt(const std::string& name, const Eigen::Vector3d& eye,
                            const Eigen::Vector3d& target, const Eigen::Vector3d& up, int width,
                            int height, double focal_px);
};

using Rig = std::vector<CameraModel>;

// Writes/reads a rig: camera_count, then camera_<i> maps with name, image_width, image_height,
// camera_matrix (3x3), distortion_coefficients (5x1), R (3x3, world -> camera), T (3x1, metres).
// loadRig throws std::runtime_error naming the file, camera and field on bad input, a value that is
// not finite included. saveRig writes any name so that loadRig reads it back, up to about 4 KB, and
// throws std::runtime_error, writing nothing, for a longer name or a value that is not finite.
void saveRig(const std::string& path, const Rig& rig);
Rig loadRig(const std::string& path);

}  // namespace mocap
