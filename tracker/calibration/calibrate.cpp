// Multi-camera calibration: per-camera intrinsics, chained extrinsics, joint refinement.
#include "tracker/calibration/calibrate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <optional>
#include <set>
#include <sstream>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

namespace mocap {

namespace {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// x_to = R(r) x_from + t.
struct Pose {
  cv::Vec3d r, t;
};

Eigen::Isometry3d toIsometry(const Pose& p) {
  cv::Matx33d rotation;
  cv::Rodrigues(p.r, rotation);
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  for (int a = 0; a < 3; ++a) {
    iso.translation()[a] = p.t[a];
    for (int b = 0; b < 3; ++b) iso.linear()(a, b) = rotation(a, b);
  }
  return iso;
}

Pose toPose(const Eigen::Isometry3d& iso) {
  cv::Matx33d rotation;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) rotation(a, b) = iso.linear()(a, b);
  Pose p;
  cv::Rodrigues(rotation, p.r);
  p.t = cv::Vec3d(iso.translation().x(), iso.translation().y(), iso.translation().z());
  return p;
}

// Mean of rigid transforms: rotations by the chordal mean (SVD of the summed matrices).
Eigen::Isometry3d averageTransforms(const std::vector<Eigen::Isometry3d>& transforms) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  for (const auto& t : transforms) {
    sum += t.linear();
    translation += t.translation();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d rotation = svd.matrixU() * svd.matrixV().transpose();
  if (rotation.determinant() < 0) {
    Eigen::Matrix3d flip = Eigen::Matrix3d::Identity();
    flip(2, 2) = -1;
    rotation = svd.matrixU() * flip * svd.matrixV().transpose();
  }
  Eigen::Isometry3d mean = Eigen::Isometry3d::Identity();
  mean.linear() = rotation;
  mean.translation() = translation / static_cast<double>(transforms.size());
  return mean;
}

// The world seen from a floor board lying face up: same x, y and z reversed (z into the board
// points down). Maps world points to board points and back (it is its own inverse).
Eigen::Isometry3d floorFlip() {
  Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
  flip.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  return flip;
}

std::vector<cv::Point3f> objectPoints(const BoardSpec& board, const BoardDetection& detection) {
  std::vector<cv::Point3f> points;
  points.reserve(detection.ids.size());
  for (int id : detection.ids) points.push_back(board.corner(id));
  return points;
}

double viewRms(const std::vector<cv::Point3f>& object, const std::vector<cv::Point2f>& image,
               const Pose& pose, const cv::Matx33d& k, const cv::Mat& distortion) {
  std::vector<cv::Point2f> projected;
  cv::projectPoints(object, pose.r, pose.t, k, distortion, projected);
  double sum = 0;
  for (std::size_t i = 0; i < image.size(); ++i) {
    const cv::Point2f d = projected[i] - image[i];
    sum += d.dot(d);
  }
  return std::sqrt(sum / std::max<std::size_t>(1, image.size()));
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

struct Intrinsics {
  cv::Matx33d k;
  cv::Mat distortion;  // 5x1
  std::map<std::string, Pose> board_in_camera;
  double rms = 0;
  std::array<bool, 9> free{};  // fx, fy, cx, cy, k1, k2, p1, p2, k3: estimated, not held at zero
};

// Refuses views that cannot fix a focal length: all boards (nearly) parallel to the image plane,
// or all tilted about one axis.
void checkTiltVariety(const CameraObservations& camera, const BoardSpec& board,
                      const CalibrationOptions& options) {
  const double f = std::max(camera.image_size.width, camera.image_size.height);
  const cv::Matx33d guess(f, 0, camera.image_size.width / 2.0, 0, f,
                          camera.image_size.height / 2.0, 0, 0, 1);
  std::vector<double> tilt_axes;
  double max_tilt = 0;
  for (const auto& [name, detection] : camera.views) {
    cv::Vec3d r, t;
    if (!cv::solvePnP(objectPoints(board, detection), detection.pixels, guess, cv::noArray(), r, t,
                      false, cv::SOLVEPNP_IPPE))
      continue;
    cv::Matx33d rotation;
    cv::Rodrigues(r, rotation);
    const cv::Vec3d normal(rotation(0, 2), rotation(1, 2), rotation(2, 2));
    const double tilt = std::acos(std::min(1.0, std::abs(normal[2]))) * 180 / M_PI;
    max_tilt = std::max(max_tilt, tilt);
    if (tilt >= options.min_tilt_deg)
      tilt_axes.push_back(std::fmod(std::atan2(normal[1], normal[0]) * 180 / M_PI + 360, 180));
  }
  double spread = 0;
  for (double a : tilt_axes)
    for (double b : tilt_axes) {
      const double d = std::abs(a - b);
      spread = std::max(spread, std::min(d, 180 - d));
    }
  std::ostringstream message;
  message.precision(3);
  if (static_cast<int>(tilt_axes.size()) < options.min_tilted_views) {
    message << "camera " << camera.name << ": the board is nearly parallel to the image in "
            << camera.views.size() - tilt_axes.size() << " of " << camera.views.size()
            << " views (largest tilt " << max_tilt << " deg; need " << options.min_tilted_views
            << " views tilted by at least " << options.min_tilt_deg
            << " deg): the focal length is not constrained; add views with the board tilted "
               "20-45 deg in several directions";
    throw CalibrationError(message.str());
  }
  if (spread < options.min_tilt_axis_spread_deg) {
    message << "camera " << camera.name << ": all tilted views turn the board about the same axis "
            << "(spread " << spread << " deg, need " << options.min_tilt_axis_spread_deg
            << "): the focal lengths are not both constrained; tilt the board in other directions";
    throw CalibrationError(message.str());
  }
}

Intrinsics calibrateIntrinsics(const CameraObservations& observed, const BoardSpec& board,
                               const CalibrationOptions& options,
                               std::vector<RejectedView>& rejected) {
  // A partial (ChArUco) view with a few corners, or all on one line, has no unique board pose:
  // calibrateCamera would fail on it or be skewed by it.
  CameraObservations camera{observed.name, observed.image_size, {}};
  std::string first_problem;
  for (const auto& [name, detection] : observed.views) {
    const std::string problem = detectionProblem(board, detection);
    if (problem.empty()) {
      camera.views.emplace(name, detection);
      continue;
    }
    rejected.push_back({camera.name, name, problem});
    if (first_problem.empty()) first_problem = " (view " + name + ": " + problem + ")";
  }
  if (static_cast<int>(camera.views.size()) < options.min_views) {
    const std::size_t dropped = observed.views.size() - camera.views.size();
    throw CalibrationError(
        "camera " + camera.name + ": only " + std::to_string(camera.views.size()) +
        " views with a detected board (need at least " + std::to_string(options.min_views) + ")" +
        (dropped ? "; " + std::to_string(dropped) + " more dropped as unusable" + first_problem
                 : std::string()));
  }
  checkTiltVariety(camera, board, options);

  std::vector<std::string> names;
  for (const auto& entry : camera.views) names.push_back(entry.first);
  Intrinsics result;
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<std::vector<cv::Point3f>> object;
    std::vector<std::vector<cv::Point2f>> image;
    for (const auto& name : names) {
      object.push_back(objectPoints(board, camera.views.at(name)));
      image.push_back(camera.views.at(name).pixels);
    }
    cv::Mat k, distortion;
    std::vector<cv::Mat> rvecs, tvecs;
    // Tangential distortion trades off against the principal point unless the board covers the
    // whole image in many views; modern lenses have little of it. k3 needs many views too.
    const int flags = (options.estimate_tangential ? 0 : cv::CALIB_ZERO_TANGENT_DIST) |
                      (names.size() < 10 ? cv::CALIB_FIX_K3 : 0);
    result.free = {true,
                   true,
                   true,
                   true,
                   true,
                   true,
                   options.estimate_tangential,
                   options.estimate_tangential,
                   (flags & cv::CALIB_FIX_K3) == 0};
    result.rms = cv::calibrateCamera(
        object, image, camera.image_size, k, distortion, rvecs, tvecs, flags,
        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
    result.k = cv::Matx33d(k);
    result.distortion = distortion.reshape(1, 5).clone();
    result.board_in_camera.clear();
    std::vector<double> rms(names.size());
    for (std::size_t i = 0; i < names.size(); ++i) {
      Pose pose{cv::Vec3d(rvecs[i]), cv::Vec3d(tvecs[i])};
      result.board_in_camera[names[i]] = pose;
      rms[i] = viewRms(object[i], image[i], pose, result.k, result.distortion);
    }
    if (pass == 1) break;
    std::vector<double> sorted = rms;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = std::max(options.max_view_rms_px, 3 * sorted[sorted.size() / 2]);
    std::vector<std::string> kept;
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (rms[i] <= limit) {
        kept.push_back(names[i]);
        continue;
      }
      std::ostringstream reason;
      reason.precision(3);
      reason << "reprojection RMS " << rms[i] << " px (limit " << limit << " px)";
      rejected.push_back({camera.name, names[i], reason.str()});
    }
    if (kept.size() == names.size()) break;
    if (static_cast<int>(kept.size()) < options.min_views)
      throw CalibrationError("camera " + camera.name + ": only " + std::to_string(kept.size()) +
                             " views left after dropping outliers (need " +
                             std::to_string(options.min_views) + ")");
    names = kept;
  }
  return result;
}

// One camera's detection of one view, with the board points it saw.
struct Observation {
  int camera;
  int board;  // index into the refined boards
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
};

// Camera parameters refined jointly: pose (6), then fx, fy, cx, cy, k1, k2, p1, p2, k3 in the
// order of projectPoints' Jacobian columns.
constexpr int kCameraParameters = 15;
constexpr int kIntrinsicParameters = 9;

// Joint refinement of every camera pose (world -> camera), every camera's intrinsics and every
// board pose (board -> world) by Levenberg-Marquardt on reprojection error. One fixed pose sets
// the gauge; `free_intrinsics[c][i]` says which intrinsics of camera c move. Refining intrinsics
// here and not only per camera matters: a board seen by several cameras has one pose, which ties
// each camera's focal length and principal point to the others' views; per camera they are weakly
// fixed by small boards and trade off against the board distances.
void bundleAdjust(std::vector<Pose>& cameras, std::vector<Pose>& boards,
                  const std::vector<Observation>& observations, std::vector<Intrinsics>& intrinsics,
                  const std::vector<std::array<bool, kIntrinsicParameters>>& free_intrinsics,
                  int fixed_camera, int fixed_board, int iterations) {
  const int camera_count = static_cast<int>(cameras.size());
  const int parameters = kCameraParameters * camera_count + 6 * static_cast<int>(boards.size());
  const int board_base = kCameraParameters * camera_count;
  auto evaluate = [&](const std::vector<Pose>& cams, const std::vector<Pose>& brds,
                      const std::vector<Intrinsics>& ins, Eigen::MatrixXd* jtj,
                      Eigen::VectorXd* jtr) {
    double cost = 0;
    for (const Observation& o : observations) {
      const Pose& c = cams[o.camera];
      const Pose& b = brds[o.board];
      cv::Mat r3, t3, dr3dr1, dr3dt1, dr3dr2, dr3dt2, dt3dr1, dt3dt1, dt3dr2, dt3dt2;
      cv::composeRT(b.r, b.t, c.r, c.t, r3, t3, dr3dr1, dr3dt1, dr3dr2, dr3dt2, dt3dr1, dt3dt1,
                    dt3dr2, dt3dt2);
      std::vector<cv::Point2f> projected;
      cv::Mat jacobian;
      const Intrinsics& in = ins[o.camera];
      cv::projectPoints(o.object, r3, t3, in.k, in.distortion, projected, jacobian);
      const int n = static_cast<int>(o.image.size());
      Eigen::VectorXd residual(2 * n);
      for (int i = 0; i < n; ++i) {
        residual[2 * i] = projected[i].x - o.image[i].x;
        residual[2 * i + 1] = projected[i].y - o.image[i].y;
      }
      cost += residual.squaredNorm();
      if (!jtj) continue;
      auto map = [](const cv::Mat& m) {
        cv::Mat d;
        m.convertTo(d, CV_64F);
        return RowMatrix(Eigen::Map<const RowMatrix>(d.ptr<double>(), d.rows, d.cols));
      };
      const RowMatrix j = map(jacobian);
      const RowMatrix j_r = j.leftCols(3), j_t = j.middleCols(3, 3);
      Eigen::MatrixXd j_camera(2 * n, kCameraParameters), j_board(2 * n, 6);
      j_camera.leftCols(6) << j_r * map(dr3dr2) + j_t * map(dt3dr2),
          j_r * map(dr3dt2) + j_t * map(dt3dt2);
      j_camera.rightCols(kIntrinsicParameters) = j.middleCols(6, kIntrinsicParameters);
      for (int i = 0; i < kIntrinsicParameters; ++i)
        if (!free_intrinsics[o.camera][i]) j_camera.col(6 + i).setZero();
      if (o.camera == fixed_camera) j_camera.leftCols(6).setZero();
      j_board << j_r * map(dr3dr1) + j_t * map(dt3dr1), j_r * map(dr3dt1) + j_t * map(dt3dt1);
      if (o.board == fixed_board) j_board.setZero();
      const int oc = kCameraParameters * o.camera, ob = board_base + 6 * o.board;
      jtj->block<kCameraParameters, kCameraParameters>(oc, oc) += j_camera.transpose() * j_camera;
      jtr->segment<kCameraParameters>(oc) += j_camera.transpose() * residual;
      jtj->block<6, 6>(ob, ob) += j_board.transpose() * j_board;
      jtr->segment<6>(ob) += j_board.transpose() * residual;
      const Eigen::Matrix<double, kCameraParameters, 6> cross = j_camera.transpose() * j_board;
      jtj->block<kCameraParameters, 6>(oc, ob) += cross;
      jtj->block<6, kCameraParameters>(ob, oc) += cross.transpose();
    }
    return cost;
  };

  double lambda = 1e-3;
  for (int iteration = 0; iteration < iterations; ++iteration) {
    Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(parameters, parameters);
    Eigen::VectorXd jtr = Eigen::VectorXd::Zero(parameters);
    const double cost = evaluate(cameras, boards, intrinsics, &jtj, &jtr);
    bool improved = false;
    for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
      Eigen::MatrixXd damped = jtj;
      // Fixed parameters have all-zero rows: the unit diagonal keeps their step at zero.
      for (int i = 0; i < parameters; ++i)
        damped(i, i) += jtj(i, i) == 0 ? 1.0 : lambda * jtj(i, i) + 1e-12;
      const Eigen::VectorXd step = damped.ldlt().solve(-jtr);
      std::vector<Pose> next_cameras = cameras, next_boards = boards;
      std::vector<Intrinsics> next_intrinsics = intrinsics;
      auto apply = [&](Pose& p, int offset) {
        for (int a = 0; a < 3; ++a) {
          p.r[a] += step[offset + a];
          p.t[a] += step[offset + 3 + a];
        }
      };
      for (int c = 0; c < camera_count; ++c) {
        const int offset = kCameraParameters * c;
        apply(next_cameras[c], offset);
        Intrinsics& in = next_intrinsics[c];
        in.distortion = in.distortion.clone();
        in.k(0, 0) += step[offset + 6];
        in.k(1, 1) += step[offset + 7];
        in.k(0, 2) += step[offset + 8];
        in.k(1, 2) += step[offset + 9];
        for (int d = 0; d < 5; ++d) in.distortion.at<double>(d) += step[offset + 10 + d];
      }
      for (int b = 0; b < static_cast<int>(boards.size()); ++b)
        apply(next_boards[b], board_base + 6 * b);
      const double next_cost =
          evaluate(next_cameras, next_boards, next_intrinsics, nullptr, nullptr);
      if (next_cost < cost) {
        cameras = std::move(next_cameras);
        boards = std::move(next_boards);
        intrinsics = std::move(next_intrinsics);
        lambda = std::max(lambda / 3, 1e-9);
        improved = true;
        if (cost - next_cost < 1e-10 * cost) return;  // converged
      } else {
        lambda *= 5;
      }
    }
    if (!improved) return;
  }
}

}  // namespace

CalibrationResult calibrateRig(const std::vector<CameraObservations>& cameras,
                               const BoardSpec& board, const CalibrationOptions& options) {
  validateBoard(board);
  if (cameras.empty()) throw CalibrationError("no camera to calibrate");
  CalibrationResult result;
  const int camera_count = static_cast<int>(cameras.size());
  std::vector<Intrinsics> intrinsics;
  for (const CameraObservations& camera : cameras)
    intrinsics.push_back(calibrateIntrinsics(camera, board, options, result.rejected));

  // Place cameras in the world, starting from the floor view (or camera 0) and chaining through
  // views seen by an already placed camera, most shared views first.
  std::vector<std::optional<Eigen::Isometry3d>> camera_from_world(camera_count);
  if (!options.floor_view.empty()) {
    for (int c = 0; c < camera_count; ++c) {
      auto it = intrinsics[c].board_in_camera.find(options.floor_view);
      if (it != intrinsics[c].board_in_camera.end())
        camera_from_world[c] = toIsometry(it->second) * floorFlip();
    }
    if (std::none_of(camera_from_world.begin(), camera_from_world.end(),
                     [](const auto& t) { return t.has_value(); }))
      throw CalibrationError("floor view '" + options.floor_view +
                             "': no camera detected the board in it (or it was rejected)");
  } else {
    camera_from_world[0] = Eigen::Isometry3d::Identity();
    result.warnings.push_back("no floor view given: the world frame is camera " + cameras[0].name +
                              "'s, and Z is not up");
  }
  for (;;) {
    int best = -1;
    std::vector<Eigen::Isometry3d> best_estimates;
    for (int b = 0; b < camera_count; ++b) {
      if (camera_from_world[b]) continue;
      std::vector<Eigen::Isometry3d> estimates;
      for (const auto& [view, board_in_b] : intrinsics[b].board_in_camera)
        for (int a = 0; a < camera_count; ++a) {
          if (!camera_from_world[a]) continue;
          auto it = intrinsics[a].board_in_camera.find(view);
          if (it == intrinsics[a].board_in_camera.end()) continue;
          estimates.push_back(toIsometry(board_in_b) * toIsometry(it->second).inverse() *
                              *camera_from_world[a]);
        }
      if (estimates.size() > best_estimates.size()) {
        best = b;
        best_estimates = std::move(estimates);
      }
    }
    if (best < 0) break;
    camera_from_world[best] = averageTransforms(best_estimates);
  }
  std::vector<std::string> placed, unplaced;
  for (int c = 0; c < camera_count; ++c)
    (camera_from_world[c] ? placed : unplaced).push_back(cameras[c].name);
  if (!unplaced.empty())
    throw CalibrationError("camera(s) " + joined(unplaced) + " share no board view with camera(s) " +
                           joined(placed) + ": each camera needs views (same image name) in which "
                           "the board is also seen by a camera already placed");

  // Every kept view is refined: those seen by one camera still constrain its intrinsics.
  std::map<std::string, std::vector<int>> seen_by;
  for (int c = 0; c < camera_count; ++c)
    for (const auto& entry : intrinsics[c].board_in_camera) seen_by[entry.first].push_back(c);
  std::vector<Pose> camera_poses(camera_count), board_poses;
  for (int c = 0; c < camera_count; ++c) camera_poses[c] = toPose(*camera_from_world[c]);
  std::vector<Observation> observations;
  int fixed_board = -1;
  for (const auto& [view, list] : seen_by) {
    const bool is_floor = view == options.floor_view;
    std::vector<Eigen::Isometry3d> estimates;
    for (int c : list)
      estimates.push_back(camera_from_world[c]->inverse() *
                          toIsometry(intrinsics[c].board_in_camera.at(view)));
    const int index = static_cast<int>(board_poses.size());
    board_poses.push_back(toPose(is_floor ? floorFlip() : averageTransforms(estimates)));
    if (is_floor) fixed_board = index;
    for (int c : list) {
      const BoardDetection& detection = cameras[c].views.at(view);
      observations.push_back({c, index, objectPoints(board, detection), detection.pixels});
    }
  }
  std::vector<std::array<bool, kIntrinsicParameters>> free_intrinsics;
  for (const Intrinsics& in : intrinsics) free_intrinsics.push_back(in.free);
  bundleAdjust(camera_poses, board_poses, observations, intrinsics, free_intrinsics,
               fixed_board < 0 ? 0 : -1, fixed_board, options.bundle_iterations);

  std::vector<double> squared(camera_count, 0.0);
  std::vector<long> counted(camera_count, 0);
  double total_squared = 0;
  long total_counted = 0;
  for (const Observation& o : observations) {
    cv::Vec3d r, t;
    cv::composeRT(board_poses[o.board].r, board_poses[o.board].t, camera_poses[o.camera].r,
                  camera_poses[o.camera].t, r, t);
    const double rms = viewRms(o.object, o.image, {r, t}, intrinsics[o.camera].k,
                               intrinsics[o.camera].distortion);
    squared[o.camera] += rms * rms * o.image.size();
    counted[o.camera] += static_cast<long>(o.image.size());
  }
  for (int c = 0; c < camera_count; ++c) {
    total_squared += squared[c];
    total_counted += counted[c];
    const Intrinsics& in = intrinsics[c];
    CameraModel model;
    model.name = cameras[c].name;
    model.width = cameras[c].image_size.width;
    model.height = cameras[c].image_size.height;
    model.fx = in.k(0, 0);
    model.fy = in.k(1, 1);
    model.cx = in.k(0, 2);
    model.cy = in.k(1, 2);
    for (int i = 0; i < 5; ++i) model.distortion[i] = in.distortion.at<double>(i);
    const Eigen::Isometry3d pose = toIsometry(camera_poses[c]);
    model.rotation = pose.linear();
    model.translation = pose.translation();
    result.rig.push_back(model);
    result.cameras.push_back({cameras[c].name, static_cast<int>(in.board_in_camera.size()), in.rms,
                              counted[c] ? std::sqrt(squared[c] / counted[c]) : 0.0});
  }
  result.rig_rms_px = total_counted ? std::sqrt(total_squared / total_counted) : 0.0;
  return result;
}

std::vector<CameraObservations> detectImageFolders(const std::string& root, const BoardSpec& board,
                                                   std::vector<RejectedView>& rejected) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(root, error))
    throw CalibrationError(root + ": not a directory (expected one subfolder of images per camera)");
  std::vector<fs::path> folders;
  for (const auto& entry : fs::directory_iterator(root, error))
    if (entry.is_directory()) folders.push_back(entry.path());
  std::sort(folders.begin(), folders.end());
  if (folders.empty())
    throw CalibrationError(root + ": no camera subfolder (expected one folder of images per camera)");
  const std::set<std::string> extensions = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"};
  const BoardDetector detector(board);
  std::vector<CameraObservations> cameras;
  for (const fs::path& folder : folders) {
    CameraObservations camera;
    camera.name = folder.filename().string();
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(folder, error)) {
      std::string ext = entry.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) {
        return static_cast<char>(std::tolower(ch));
      });
      if (entry.is_regular_file() && extensions.count(ext)) files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    if (files.empty()) throw CalibrationError(folder.string() + ": no image files");
    for (const fs::path& file : files) {
      const std::string view = file.stem().string();
      const cv::Mat image = cv::imread(file.string(), cv::IMREAD_GRAYSCALE);
      if (image.empty()) {
        rejected.push_back({camera.name, view, "cannot read " + file.string()});
        continue;
      }
      if (camera.image_size.area() == 0) camera.image_size = image.size();
      if (image.size() != camera.image_size) {
        rejected.push_back({camera.name, view, "image size differs from the camera's first image"});
        continue;
      }
      BoardDetection detection;
      std::string why;
      if (detector.detect(image, detection, why))
        camera.views[view] = std::move(detection);
      else
        rejected.push_back({camera.name, view, why});
    }
    cameras.push_back(std::move(camera));
  }
  return cameras;
}

}  // namespace mocap
