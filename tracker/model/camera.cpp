// Camera projection and rig file I/O.
#include "tracker/model/camera.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>

namespace mocap {

Eigen::Vector2d CameraModel::projectCameraPoint(const Eigen::Vector3d& p) const {
  const double x = p.x() / p.z();
  const double y = p.y() / p.z();
  const auto& [k1, k2, p1, p2, k3] = distortion;
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {fx * xd + cx, fy * yd + cy};
}

bool CameraModel::project(const Eigen::Vector3d& world, Eigen::Vector2d& pixel) const {
  const Eigen::Vector3d p = toCamera(world);
  if (p.z() < kMinDepth) return false;
  pixel = projectCameraPoint(p);
  return true;
}

Eigen::Vector3d CameraModel::backProject(const Eigen::Vector2d& pixel) const {
  const double xd = (pixel.x() - cx) / fx;
  const double yd = (pixel.y() - cy) / fy;
  const auto& [k1, k2, p1, p2, k3] = distortion;
  double x = xd, y = yd;
  // The distortion is a small correction within the image, so x = (xd - tangential) / radial
  // converges in a few rounds; 20 bring it to the rounding of a double for lenses seen here.
  for (int i = 0; i < 20; ++i) {
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    x = (xd - 2 * p1 * x * y - p2 * (r2 + 2 * x * x)) / radial;
    y = (yd - p1 * (r2 + 2 * y * y) - 2 * p2 * x * y) / radial;
  }
  return (rotation.transpose() * Eigen::Vector3d(x, y, 1)).normalized();
}

CameraModel CameraModel::lookAt(const std::string& name, const Eigen::Vector3d& eye,
                                const Eigen::Vector3d& target, const Eigen::Vector3d& up, int width,
                                int height, double focal_px) {
  CameraModel cam;
  cam.name = name;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = focal_px;
  cam.cx = width / 2.0;
  cam.cy = height / 2.0;
  const Eigen::Vector3d forward = (target - eye).normalized();  // camera z
  Eigen::Vector3d right = forward.cross(up);                    // camera x
  if (right.norm() < 1e-9) right = forward.unitOrthogonal();
  right.normalize();
  const Eigen::Vector3d down = forward.cross(right);  // camera y
  cam.rotation.row(0) = right.transpose();
  cam.rotation.row(1) = down.transpose();
  cam.rotation.row(2) = forward.transpose();
  cam.translation = -cam.rotation * eye;
  return cam;
}

void saveRig(const std::string& path, const Rig& rig) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot open for writing");
  fs << "camera_count" << static_cast<int>(rig.size());
  for (std::size_t i = 0; i < rig.size(); ++i) {
    const CameraModel& c = rig[i];
    cv::Mat k = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
    cv::Mat dist(5, 1, CV_64F);
    for (int j = 0; j < 5; ++j) dist.at<double>(j) = c.distortion[j];
    cv::Mat r(3, 3, CV_64F), t(3, 1, CV_64F);
    for (int a = 0; a < 3; ++a) {
      t.at<double>(a) = c.translation[a];
      for (int b = 0; b < 3; ++b) r.at<double>(a, b) = c.rotation(a, b);
    }
    fs << "camera_" + std::to_string(i) << "{";
    fs << "name" << c.name << "image_width" << c.width << "image_height" << c.height;
    fs << "camera_matrix" << k << "distortion_coefficients" << dist << "R" << r << "T" << t;
    fs << "}";
  }
}

namespace {

// Any non-empty OpenCV matrix at `node` (OpenCV asserts on a malformed one: named here instead).
cv::Mat readAnyMatrix(const cv::FileNode& node, const std::string& where) {
  if (node.empty()) throw std::runtime_error(where + ": missing");
  // OpenCV allocates rows x cols before it reads the data: more than a rig's matrices hold is
  // refused first, so a corrupt size cannot ask for gigabytes.
  constexpr double kMaxValues = 16;
  cv::Mat m;
  try {
    const double values =
        static_cast<double>(static_cast<int>(node["rows"])) * static_cast<int>(node["cols"]);
    if (values > kMaxValues)
      throw std::runtime_error(where + ": " + std::to_string(static_cast<int>(node["rows"])) + "x" +
                               std::to_string(static_cast<int>(node["cols"])) +
                               " is larger than any matrix of a rig");
    node >> m;
  } catch (const cv::Exception&) {
    throw std::runtime_error(where + ": not an OpenCV matrix");
  }
  if (m.empty()) throw std::runtime_error(where + ": not an OpenCV matrix");
  return m;
}

cv::Mat readMatrix(const cv::FileNode& node, const std::string& where, int rows, int cols) {
  cv::Mat m = readAnyMatrix(node, where);
  if (m.total() != static_cast<std::size_t>(rows * cols) || (m.rows != rows && m.cols != rows)) {
    throw std::runtime_error(where + ": expected " + std::to_string(rows) + "x" +
                             std::to_string(cols) + ", got " + std::to_string(m.rows) + "x" +
                             std::to_string(m.cols));
  }
  m.convertTo(m, CV_64F);
  return m.reshape(1, rows);
}

int readPositiveInt(const cv::FileNode& node, const std::string& where) {
  if (node.empty() || !node.isInt())
    throw std::runtime_error(where + ": missing or not an integer");
  const int v = static_cast<int>(node);
  if (v <= 0) throw std::runtime_error(where + ": must be positive, got " + std::to_string(v));
  return v;
}

Rig readRig(const cv::FileStorage& fs, const std::string& path) {
  const int count = readPositiveInt(fs["camera_count"], path + ": camera_count");
  Rig rig;
  for (int i = 0; i < count; ++i) {
    const std::string key = "camera_" + std::to_string(i);
    const std::string where = path + ": " + key;
    cv::FileNode node = fs[key];
    if (node.empty() || !node.isMap()) throw std::runtime_error(where + ": missing");
    CameraModel c;
    c.name = node["name"].empty() ? key : static_cast<std::string>(node["name"]);
    c.width = readPositiveInt(node["image_width"], where + ".image_width");
    c.height = readPositiveInt(node["image_height"], where + ".image_height");
    cv::Mat k = readMatrix(node["camera_matrix"], where + ".camera_matrix", 3, 3);
    c.fx = k.at<double>(0, 0);
    c.fy = k.at<double>(1, 1);
    c.cx = k.at<double>(0, 2);
    c.cy = k.at<double>(1, 2);
    if (c.fx <= 0 || c.fy <= 0)
      throw std::runtime_error(where + ".camera_matrix: focal lengths must be positive");
    if (!node["distortion_coefficients"].empty()) {
      cv::Mat d =
          readAnyMatrix(node["distortion_coefficients"], where + ".distortion_coefficients");
      if (d.total() < 4 || d.total() > 5)
        throw std::runtime_error(where + ".distortion_coefficients: expected 4 or 5 values");
      d.convertTo(d, CV_64F);
      for (std::size_t j = 0; j < d.total(); ++j)
        c.distortion[j] = d.at<double>(static_cast<int>(j));
    }
    cv::Mat r = readMatrix(node["R"], where + ".R", 3, 3);
    cv::Mat t = readMatrix(node["T"], where + ".T", 3, 1);
    for (int a = 0; a < 3; ++a) {
      c.translation[a] = t.at<double>(a);
      for (int b = 0; b < 3; ++b) c.rotation(a, b) = r.at<double>(a, b);
    }
    const double orthogonality =
        (c.rotation * c.rotation.transpose() - Eigen::Matrix3d::Identity()).norm();
    if (orthogonality > 1e-4 || c.rotation.determinant() < 0)
      throw std::runtime_error(where + ".R: not a rotation matrix");
    rig.push_back(c);
  }
  return rig;
}

}  // namespace

Rig loadRig(const std::string& path) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": not a readable OpenCV FileStorage file: " + e.err);
  } catch (const std::exception& e) {
    // OpenCV's YAML parser lets some malformed text out as std::length_error.
    throw std::runtime_error(path + ": not a readable OpenCV FileStorage file: " + e.what());
  }
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot open camera rig file");
  // OpenCV asserts on a file of another shape (a list or a scalar where a map belongs): named here.
  try {
    return readRig(fs, path);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": not a camera rig: " + e.err);
  }
}

}  // namespace mocap
