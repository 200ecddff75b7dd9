// The `calibration` experiment and its mocap-experiment command.
#include "tracker/calibration/calibration_experiment.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tracker/experiments/args.h"
#include "tracker/experiments/commands.h"

namespace mocap {

namespace {

Eigen::Matrix3d axisRotation(const Eigen::Vector3d& axis, double degrees) {
  return Eigen::AngleAxisd(degrees * M_PI / 180, axis).toRotationMatrix();
}

// Cameras on an arc in front of the scene (looking toward +Y), alternating heights, each with its
// own focal length, principal point and lens distortion.
Rig truthRig(int cameras, int width, int height, const Eigen::Vector3d& centre) {
  Rig rig;
  for (int i = 0; i < cameras; ++i) {
    const double azimuth = cameras == 1 ? 0.0 : (-60.0 + 120.0 * i / (cameras - 1)) * M_PI / 180;
    const Eigen::Vector3d eye =
        centre + Eigen::Vector3d(2.4 * std::sin(azimuth), -2.4 * std::cos(azimuth),
                                 1.4 + 0.2 * (i % 2));
    CameraModel camera = CameraModel::lookAt("cam" + std::to_string(i), eye,
                                             centre + Eigen::Vector3d(0, 0, 0.5),
                                             Eigen::Vector3d::UnitZ(), width, height,
                                             (700.0 + 40 * i) * height / 580.0);
    camera.fy = camera.fx * 1.002;
    camera.cx += 6.0 * i - 8;
    camera.cy += 5.0 - 3.0 * i;
    camera.distortion = {-0.12 + 0.03 * i, 0.05, 0.0, 0.0, 0.0};
    rig.push_back(camera);
  }
  return rig;
}

cv::Matx33d intrinsicMatrix(const CameraModel& c) {
  return cv::Matx33d(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
}

std::vector<double> distortionVector(const CameraModel& c) {
  return {c.distortion.begin(), c.distortion.end()};
}

}  // namespace

RenderedCalibration renderCalibrationViews(const CalibrationExperimentConfig& config) {
  if (config.cameras < 1 || config.views < 2)
    throw std::invalid_argument("need at least 1 camera and 2 views");
  RenderedCalibration out;
  out.board.type = config.board;
  out.board.cols = 9;
  out.board.rows = 6;
  out.board.square = 0.06;
  out.board.marker = 0.045;
  const Eigen::Vector3d board_centre_local((out.board.cols - 2) * out.board.square / 2,
                                           (out.board.rows - 2) * out.board.square / 2, 0);
  // World = the floor board, face up: board (x, y, 0) is world (x, -y, 0).
  const Eigen::Vector3d centre(board_centre_local.x(), -board_centre_local.y(), 0);
  out.truth = truthRig(config.cameras, config.width, config.height, centre);

  cv::Matx33d texture_to_board;
  const int pixels_per_square = 24;
  const cv::Mat texture = renderBoardImage(out.board, pixels_per_square, texture_to_board);
  cv::RNG rng(config.seed * 104729 + 3);

  // Board poses (board -> world): the floor view, then boards held in front of the cameras.
  std::vector<std::pair<std::string, Eigen::Isometry3d>> views;
  Eigen::Isometry3d floor = Eigen::Isometry3d::Identity();
  floor.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  views.emplace_back(out.floor_view, floor);
  Eigen::Matrix3d facing;
  facing.col(0) = Eigen::Vector3d::UnitX();
  facing.col(1) = -Eigen::Vector3d::UnitZ();
  facing.col(2) = Eigen::Vector3d::UnitY();
  for (int v = 1; v < config.views; ++v) {
    const Eigen::Matrix3d rotation =
        facing * axisRotation(Eigen::Vector3d::UnitX(), rng.uniform(-40.0, 40.0)) *
        axisRotation(Eigen::Vector3d::UnitY(), rng.uniform(-40.0, 40.0)) *
        axisRotation(Eigen::Vector3d::UnitZ(), rng.uniform(-15.0, 15.0));
    const Eigen::Vector3d position =
        centre + Eigen::Vector3d(rng.uniform(-0.6, 0.6), rng.uniform(-0.4, 0.4),
                                 0.55 + rng.uniform(-0.35, 0.35));
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = rotation;
    pose.translation() = position - rotation * board_centre_local;
    char name[32];
    std::snprintf(name, sizeof name, "view_%03d", v);
    views.emplace_back(name, pose);
  }

  const BoardDetector detector(out.board);
  const cv::Size size(config.width, config.height);
  const cv::Point2d margin(config.width / 4.0, config.height / 4.0);
  const cv::Size canvas(config.width + 2 * static_cast<int>(margin.x),
                        config.height + 2 * static_cast<int>(margin.y));
  for (const CameraModel& camera : out.truth) {
    CameraObservations observed;
    observed.name = camera.name;
    observed.image_size = size;
    // Where each distorted image pixel looks in the undistorted canvas.
    std::vector<cv::Point2f> pixels, ideal;
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) pixels.emplace_back(x, y);
    // Iterated to convergence: the default 5 iterations leave tenths of a pixel at the corners.
    cv::undistortPoints(pixels, ideal, intrinsicMatrix(camera), distortionVector(camera),
                        cv::noArray(), intrinsicMatrix(camera),
                        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-9));
    cv::Mat map(size, CV_32FC2);
    for (int i = 0; i < static_cast<int>(ideal.size()); ++i)
      map.at<cv::Vec2f>(i / size.width, i % size.width) =
          cv::Vec2f(ideal[i].x + static_cast<float>(margin.x), ideal[i].y + static_cast<float>(margin.y));

    for (const auto& [name, board_to_world] : views) {
      // Visible: the printed face turned toward the camera, every corner inside the image.
      Eigen::Isometry3d world_to_camera = Eigen::Isometry3d::Identity();
      world_to_camera.linear() = camera.rotation;
      world_to_camera.translation() = camera.translation;
      const Eigen::Isometry3d board_to_camera = world_to_camera * board_to_world;
      const Eigen::Vector3d to_camera =
          (camera.center() - board_to_world * board_centre_local).normalized();
      const Eigen::Vector3d face = -(board_to_world.linear().col(2));
      if (face.dot(to_camera) < std::cos(68 * M_PI / 180)) continue;
      bool inside = true;
      for (int id = 0; id < out.board.cornerCount() && inside; ++id) {
        const cv::Point3f c = out.board.corner(id);
        Eigen::Vector2d pixel;
        inside = camera.project(board_to_world * Eigen::Vector3d(c.x, c.y, c.z), pixel) &&
                 pixel.x() > 15 && pixel.y() > 15 && pixel.x() < size.width - 16 &&
                 pixel.y() < size.height - 16;
      }
      if (!inside) continue;

      const Eigen::Matrix3d r = board_to_camera.linear();
      const Eigen::Vector3d t = board_to_camera.translation();
      const cv::Matx33d plane(r(0, 0), r(0, 1), t.x(), r(1, 0), r(1, 1), t.y(), r(2, 0), r(2, 1),
                              t.z());
      const cv::Matx33d shift(1, 0, margin.x, 0, 1, margin.y, 0, 0, 1);
      const cv::Matx33d homography = shift * intrinsicMatrix(camera) * plane * texture_to_board;
      cv::Mat undistorted, image;
      cv::warpPerspective(texture, undistorted, homography, canvas, cv::INTER_LINEAR,
                          cv::BORDER_CONSTANT, cv::Scalar(110));
      cv::remap(undistorted, image, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                cv::Scalar(110));
      cv::GaussianBlur(image, image, cv::Size(0, 0), 0.6);
      cv::Mat noise(size, CV_16SC1);
      rng.fill(noise, cv::RNG::NORMAL, 0, 2.0);
      image.convertTo(image, CV_16S);
      image += noise;
      image.convertTo(image, CV_8U);
      if (!config.write_images.empty()) {
        const std::string dir = config.write_images + "/" + camera.name;
        std::filesystem::create_directories(dir);
        if (!cv::imwrite(dir + "/" + name + ".png", image))
          throw std::runtime_error(dir + ": cannot write images");
      }
      BoardDetection detection;
      std::string why;
      if (!detector.detect(image, detection, why)) {
        out.rejected.push_back({camera.name, name, why});
        continue;
      }
      for (cv::Point2f& p : detection.pixels) {
        p.x += static_cast<float>(rng.gaussian(config.noise_px));
        p.y += static_cast<float>(rng.gaussian(config.noise_px));
      }
      observed.views[name] = std::move(detection);
    }
    out.observations.push_back(std::move(observed));
  }
  return out;
}

nlohmann::json compareWithTruth(const Rig& truth, const CalibrationResult& result) {
  double focal = 0, principal = 0, translation = 0, rotation = 0;
  nlohmann::json cameras = nlohmann::json::array();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const CameraModel& t = truth[i];
    const CameraModel& e = result.rig[i];
    const double f = 50 * (std::abs(e.fx - t.fx) / t.fx + std::abs(e.fy - t.fy) / t.fy);
    const double c = std::hypot(e.cx - t.cx, e.cy - t.cy);
    const double d = 1000 * (e.center() - t.center()).norm();
    const double a =
        Eigen::AngleAxisd(e.rotation * t.rotation.transpose()).angle() * 180 / M_PI;
    focal += f;
    principal += c;
    translation += d;
    rotation += a;
    cameras.push_back({{"name", e.name},
                       {"views_used", result.cameras[i].views_used},
                       {"intrinsic_rms_px", result.cameras[i].intrinsic_rms_px},
                       {"rig_rms_px", result.cameras[i].rig_rms_px},
                       {"focal_error_pct", f},
                       {"principal_point_error_px", c},
                       {"translation_error_mm", d},
                       {"rotation_error_deg", a}});
  }
  const double n = static_cast<double>(truth.size());
  return {{"reprojection_rms_px", result.rig_rms_px},
          {"focal_error_pct", focal / n},
          {"principal_point_error_px", principal / n},
          {"extrinsic_translation_error_mm", translation / n},
          {"extrinsic_rotation_error_deg", rotation / n},
          {"cameras", cameras}};
}

nlohmann::json runCalibrationExperiment(const CalibrationExperimentConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  RenderedCalibration rendered = renderCalibrationViews(config);
  const auto rendered_at = std::chrono::steady_clock::now();
  CalibrationOptions options;
  options.floor_view = rendered.floor_view;
  CalibrationResult result = calibrateRig(rendered.observations, rendered.board, options);
  const auto end = std::chrono::steady_clock::now();
  nlohmann::json summary = compareWithTruth(rendered.truth, result);
  summary["experiment"] = "calibration";
  summary["seed"] = config.seed;
  summary["cameras_count"] = config.cameras;
  summary["views"] = config.views;
  summary["noise_px"] = config.noise_px;
  summary["board"] = config.board == BoardType::kCheckerboard ? "checkerboard" : "charuco";
  summary["views_not_detected"] = rendered.rejected.size();
  summary["views_rejected"] = result.rejected.size();
  summary["render_detect_seconds"] = std::chrono::duration<double>(rendered_at - start).count();
  summary["calibrate_seconds"] = std::chrono::duration<double>(end - rendered_at).count();
  return summary;
}

int runCalibrationCommand(int argc, char** argv) {
  const Args args(argc, argv, 2,
                  {"cameras", "views", "noise", "seed", "board", "width", "height", "write-images"},
                  {});
  CalibrationExperimentConfig config;
  config.cameras = static_cast<int>(args.integer("cameras", 4, 1, 16));
  config.views = static_cast<int>(args.integer("views", 30, 2, 1000));
  config.noise_px = args.real("noise", 0.2, 0, 10);
  config.seed = static_cast<uint64_t>(args.integer("seed", 1, 0, 1L << 40));
  config.board = parseBoardType(args.text("board", "checkerboard"));
  config.width = static_cast<int>(args.integer("width", 780, 160, 8192));
  config.height = static_cast<int>(args.integer("height", 580, 120, 8192));
  config.write_images = args.text("write-images", "");
  std::cout << runCalibrationExperiment(config).dump(2) << std::endl;
  return 0;
}

}  // namespace mocap
