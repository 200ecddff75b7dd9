// The `calibration` experiment and its mocap-experiment command.
#include "tracker/experiments/calibration_experiment.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tracker/calibration/board_flags.h"
#include "tracker/cli/args.h"
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
        centre +
        Eigen::Vector3d(2.4 * std::sin(azimuth), -2.4 * std::cos(azimuth), 1.4 + 0.2 * (i % 2));
    CameraModel camera = CameraModel::lookAt(
        "cam" + std::to_string(i), eye, centre + Eigen::Vector3d(0, 0, 0.5),
        Eigen::Vector3d::UnitZ(), width, height, (700.0 + 40 * i) * height / 580.0);
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

// For every pixel of the (distorted) image, the ideal pinhole pixel it sees. Iterated to
// convergence: the default 5 iterations leave tenths of a pixel at the image corners.
cv::Mat idealPixelMap(const CameraModel& camera, const cv::Size& size) {
  std::vector<cv::Point2f> pixels, ideal;
  pixels.reserve(size.area());
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) pixels.emplace_back(x, y);
  cv::undistortPoints(pixels, ideal, intrinsicMatrix(camera), distortionVector(camera),
                      cv::noArray(), intrinsicMatrix(camera),
                      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-9));
  return cv::Mat(ideal, true).reshape(2, size.height);
}

// Sub-pixel samples per pixel side. One sample per pixel aliases the board's edges (each edge's
// position snaps to the pixel grid: ~0.15 px RMS corner error even without noise); 4x4 samples
// with a bilinear texture whose texels are no smaller than a sample keep it a few hundredths.
constexpr int kSupersample = 4;
constexpr uchar kBackground = 110;

// The board texture seen through `camera`: every pixel averages kSupersample^2 samples, each
// traced back through the lens distortion (`ideal`, see idealPixelMap) and the board plane into
// the texture. Only the board's bounding box is supersampled; the rest is background.
cv::Mat renderView(const cv::Mat& texture, const cv::Matx33d& texture_to_board,
                   const CameraModel& camera, const Eigen::Isometry3d& board_to_camera,
                   const cv::Mat& ideal) {
  const cv::Size size = ideal.size();
  cv::Mat image(size, CV_8UC1, cv::Scalar(kBackground));
  const Eigen::Matrix3d r = board_to_camera.linear();
  const Eigen::Vector3d t = board_to_camera.translation();
  const cv::Matx33d plane(r(0, 0), r(0, 1), t.x(), r(1, 0), r(1, 1), t.y(), r(2, 0), r(2, 1),
                          t.z());
  const cv::Matx33d texture_to_ideal = intrinsicMatrix(camera) * plane * texture_to_board;
  const cv::Matx33d ideal_to_texture = texture_to_ideal.inv();

  // Bounding box of the texture's outline (bent by the distortion, hence sampled along edges).
  double x0 = size.width, y0 = size.height, x1 = 0, y1 = 0;
  const double tw = texture.cols, th = texture.rows;
  for (int i = 0; i <= 40; ++i) {
    const double s = i / 40.0;
    for (const cv::Point2d& p : {cv::Point2d(s * tw, 0), cv::Point2d(s * tw, th),
                                 cv::Point2d(0, s * th), cv::Point2d(tw, s * th)}) {
      const cv::Point2d texel(p.x - 0.5, p.y - 0.5);  // texture edge in pixel-centre coordinates
      const cv::Vec3d board = texture_to_board * cv::Vec3d(texel.x, texel.y, 1);
      const Eigen::Vector3d in_camera =
          board_to_camera * Eigen::Vector3d(board[0] / board[2], board[1] / board[2], 0);
      if (in_camera.z() < CameraModel::kMinDepth) return image;  // not expected for shown views
      const Eigen::Vector2d pixel = camera.projectCameraPoint(in_camera);
      x0 = std::min(x0, pixel.x());
      y0 = std::min(y0, pixel.y());
      x1 = std::max(x1, pixel.x());
      y1 = std::max(y1, pixel.y());
    }
  }
  const cv::Rect box =
      cv::Rect(
          cv::Point(static_cast<int>(std::floor(x0)) - 3, static_cast<int>(std::floor(y0)) - 3),
          cv::Point(static_cast<int>(std::ceil(x1)) + 4, static_cast<int>(std::ceil(y1)) + 4)) &
      cv::Rect(cv::Point(0, 0), size);
  if (box.empty()) return image;

  // Sample (i, j) of pixel (x, y) sits at (x - 0.5 + (i + 0.5) / S, ...); its ideal position is
  // interpolated from the per-pixel map (the distortion is smooth at that scale).
  const int n = kSupersample;
  cv::Mat to_texture(box.height * n, box.width * n, CV_32FC2);
  for (int sy = 0; sy < to_texture.rows; ++sy) {
    const double v = box.y - 0.5 + (sy + 0.5) / n;
    const double vc = std::clamp(v, 0.0, size.height - 1.0);
    const int yi = std::min(static_cast<int>(vc), size.height - 2);
    const double fy = vc - yi;
    const cv::Vec2f* row0 = ideal.ptr<cv::Vec2f>(yi);
    const cv::Vec2f* row1 = ideal.ptr<cv::Vec2f>(yi + 1);
    cv::Vec2f* out = to_texture.ptr<cv::Vec2f>(sy);
    for (int sx = 0; sx < to_texture.cols; ++sx) {
      const double u = box.x - 0.5 + (sx + 0.5) / n;
      const double uc = std::clamp(u, 0.0, size.width - 1.0);
      const int xi = std::min(static_cast<int>(uc), size.width - 2);
      const double fx = uc - xi;
      // Outside the image's pixel centres the map is extended linearly from its edge.
      double px = 0, py = 0;
      for (int c = 0; c < 2; ++c) {
        const double top = row0[xi][c] * (1 - fx) + row0[xi + 1][c] * fx;
        const double bottom = row1[xi][c] * (1 - fx) + row1[xi + 1][c] * fx;
        (c == 0 ? px : py) = top * (1 - fy) + bottom * fy;
      }
      px += (u - uc) * (row0[xi + 1][0] - row0[xi][0]);
      py += (v - vc) * (row1[xi][1] - row0[xi][1]);
      const cv::Vec3d h = ideal_to_texture * cv::Vec3d(px, py, 1);
      out[sx] = cv::Vec2f(static_cast<float>(h[0] / h[2]), static_cast<float>(h[1] / h[2]));
    }
  }
  cv::Mat samples, averaged;
  cv::remap(texture, samples, to_texture, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar(kBackground));
  // Integer factor: INTER_AREA is the exact mean of each pixel's samples.
  cv::resize(samples, averaged, box.size(), 0, 0, cv::INTER_AREA);
  averaged.copyTo(image(box));
  return image;
}

}  // namespace

BoardSpec experimentBoard(BoardType type) {
  BoardSpec board;
  board.type = type;
  if (type == BoardType::kCheckerboard) {
    board.cols = 9;
    board.rows = 6;
    board.square = 0.06;
    board.marker = 0.045;
    return board;
  }
  // Markers must decode 2-3 m away: with 11 cm squares a bit of a 5x5 marker (7 cells with its
  // border) is 1.2 cm, 3-4 px in these cameras. 7x5 squares fit an A1 sheet (84 x 59 cm); an odd
  // row count keeps the pattern the same in OpenCV before and after 4.6 (4.6 changed even ones).
  board.cols = 7;
  board.rows = 5;
  board.square = 0.11;
  board.marker = 0.0825;
  board.dictionary = "5X5_100";
  return board;
}

RenderedCalibration renderCalibrationViews(const CalibrationExperimentConfig& config) {
  if (config.cameras < 1 || config.views < 2)
    throw std::invalid_argument("need at least 1 camera and 2 views");
  RenderedCalibration out;
  out.board = config.custom_board ? *config.custom_board : experimentBoard(config.board);
  validateBoard(out.board);
  const bool charuco = out.board.type == BoardType::kCharuco;
  const Eigen::Vector3d board_centre_local((out.board.cols - 2) * out.board.square / 2,
                                           (out.board.rows - 2) * out.board.square / 2, 0);
  // World = the floor board, face up: board (x, y, 0) is world (x, -y, 0).
  const Eigen::Vector3d centre(board_centre_local.x(), -board_centre_local.y(), 0);
  out.truth = truthRig(config.cameras, config.width, config.height, centre);

  cv::Matx33d texture_to_board;
  // A ChArUco marker bit needs several texels to keep its edges where they belong.
  const int pixels_per_square = charuco ? 60 : 24;
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
  for (const auto& [name, pose] : views) out.board_poses[name] = pose;

  const BoardDetector detector(out.board);
  const cv::Size size(config.width, config.height);
  double detector_squared = 0;
  for (const CameraModel& camera : out.truth) {
    CameraObservations observed;
    observed.name = camera.name;
    observed.image_size = size;
    const cv::Mat ideal = idealPixelMap(camera, size);

    for (const auto& [name, board_to_world] : views) {
      // Visible: the printed face turned toward the camera, every corner inside the image; a
      // ChArUco board also partly (its corners are identified by the markers near them).
      Eigen::Isometry3d world_to_camera = Eigen::Isometry3d::Identity();
      world_to_camera.linear() = camera.rotation;
      world_to_camera.translation() = camera.translation;
      const Eigen::Isometry3d board_to_camera = world_to_camera * board_to_world;
      const Eigen::Vector3d to_camera =
          (camera.center() - board_to_world * board_centre_local).normalized();
      const Eigen::Vector3d face = -(board_to_world.linear().col(2));
      if (face.dot(to_camera) < std::cos(68 * M_PI / 180)) continue;
      int inside = 0;
      for (int id = 0; id < out.board.cornerCount(); ++id) {
        const cv::Point3f c = out.board.corner(id);
        Eigen::Vector2d pixel;
        if (camera.project(board_to_world * Eigen::Vector3d(c.x, c.y, c.z), pixel) &&
            pixel.x() > 15 && pixel.y() > 15 && pixel.x() < size.width - 16 &&
            pixel.y() < size.height - 16)
          ++inside;
        else if (!charuco)
          break;
      }
      if (charuco ? inside == 0 : inside < out.board.cornerCount()) continue;

      cv::Mat image = renderView(texture, texture_to_board, camera, board_to_camera, ideal);
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
      for (std::size_t i = 0; i < detection.ids.size(); ++i) {
        const cv::Point3f c = out.board.corner(detection.ids[i]);
        Eigen::Vector2d truth;
        camera.project(board_to_world * Eigen::Vector3d(c.x, c.y, c.z), truth);
        const double error =
            std::hypot(truth.x() - detection.pixels[i].x, truth.y() - detection.pixels[i].y);
        detector_squared += error * error;
        out.detector_max_px = std::max(out.detector_max_px, error);
      }
      out.corners_detected += static_cast<long>(detection.ids.size());
      if (static_cast<int>(detection.ids.size()) < out.board.cornerCount()) ++out.partial_views;
      for (cv::Point2f& p : detection.pixels) {
        p.x += static_cast<float>(rng.gaussian(config.noise_px));
        p.y += static_cast<float>(rng.gaussian(config.noise_px));
      }
      observed.views[name] = std::move(detection);
    }
    out.observations.push_back(std::move(observed));
  }
  if (out.corners_detected > 0)
    out.detector_rms_px = std::sqrt(detector_squared / static_cast<double>(out.corners_detected));
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
    const double a = Eigen::AngleAxisd(e.rotation * t.rotation.transpose()).angle() * 180 / M_PI;
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
  const BoardSpec& board = rendered.board;
  summary["board"] = board.type == BoardType::kCheckerboard ? "checkerboard" : "charuco";
  summary["board_spec"] = {{"cols", board.cols}, {"rows", board.rows}, {"square", board.square}};
  if (board.type == BoardType::kCharuco) {
    summary["board_spec"]["marker"] = board.marker;
    summary["board_spec"]["dictionary"] = board.dictionary;
  }
  summary["views_not_detected"] = rendered.rejected.size();
  int detected_views = 0;
  for (const CameraObservations& camera : rendered.observations)
    detected_views += static_cast<int>(camera.views.size());
  summary["views_detected"] = detected_views;
  summary["partial_views"] = rendered.partial_views;
  summary["corners_per_view"] =
      detected_views ? static_cast<double>(rendered.corners_detected) / detected_views : 0.0;
  summary["detector_rms_px"] = rendered.detector_rms_px;
  summary["detector_max_px"] = rendered.detector_max_px;
  summary["views_rejected"] = result.rejected.size();
  summary["render_detect_seconds"] = std::chrono::duration<double>(rendered_at - start).count();
  summary["calibrate_seconds"] = std::chrono::duration<double>(end - rendered_at).count();
  return summary;
}

int runCalibrationCommand(int argc, char** argv) {
  const Args args(argc, argv, 2, kCalibrationUsage);
  CalibrationExperimentConfig config;
  config.cameras = static_cast<int>(args.integer("cameras", 4, 1, 16));
  config.views = static_cast<int>(args.integer("views", 30, 2, 1000));
  config.noise_px = args.real("noise", 0.2, 0, 10);
  config.seed = static_cast<uint64_t>(args.integer("seed", 1, 0, 1L << 40));
  config.board = parseBoardType(args.text("board", "checkerboard"));
  // Board flags change the experiment's default board of that type; checked like mocapctl's.
  if (args.has("cols") || args.has("rows") || args.has("square") || args.has("marker") ||
      args.has("dictionary"))
    config.custom_board = boardFromFlags(args, experimentBoard(config.board));
  config.width = static_cast<int>(args.integer("width", 780, 160, 8192));
  config.height = static_cast<int>(args.integer("height", 580, 120, 8192));
  config.write_images = args.text("write-images", "");
  std::cout << runCalibrationExperiment(config).dump(2) << std::endl;
  return 0;
}

}  // namespace mocap
