// Multi-camera calibration from board views: intrinsics per camera (OpenCV's calibrateCamera with
// outlier views dropped), then all cameras in one world frame by chaining the board poses of views
// shared between cameras and refining every camera pose, camera intrinsics and board pose jointly
// (bundle adjustment on reprojection error). The world is the board of a designated floor view:
// origin at its first inner corner, x along its columns, Z up. Refuses, with a message naming the
// camera, inputs that do not constrain a camera.
#pragma once

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "tracker/calibration/board.h"
#include "tracker/model/camera.h"

namespace mocap {

class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What one camera saw: detections keyed by view name (the image's name, shared across cameras).
struct CameraObservations {
  std::string name;
  cv::Size image_size;
  std::map<std::string, BoardDetection> views;
};

struct RejectedView {
  std::string camera;
  std::string view;
  std::string reason;
};

struct CalibrationOptions {
  std::string floor_view;        // empty: the world is the first camera's frame (Z not up)
  int min_views = 5;             // usable views per camera
  double min_tilt_deg = 10;      // a view "tilted" if its board normal is this far off the axis
  int min_tilted_views = 3;
  double min_tilt_axis_spread_deg = 20;  // tilted views must turn about axes this far apart
  double max_view_rms_px = 1.0;  // views above this and above 3x the median are dropped
  int bundle_iterations = 50;
  bool estimate_tangential = false;  // p1, p2; off: they are zero
};

struct CameraReport {
  std::string name;
  int views_used = 0;
  double intrinsic_rms_px = 0;  // calibrateCamera's, over the camera's kept views
  double rig_rms_px = 0;        // after joint refinement (intrinsics too), over its kept views
};

struct CalibrationResult {
  Rig rig;
  std::vector<CameraReport> cameras;
  std::vector<RejectedView> rejected;
  std::vector<std::string> warnings;
  double rig_rms_px = 0;
};

// Throws CalibrationError with a message naming the camera and what to do.
CalibrationResult calibrateRig(const std::vector<CameraObservations>& cameras,
                               const BoardSpec& board, const CalibrationOptions& options);

// Detects the board in an image folder: one subfolder per camera (sorted by name), images (png,
// jpg, jpeg, bmp, tif, tiff) matched across cameras by file name without extension. Views without
// a board are added to `rejected`. Throws CalibrationError on a missing/empty folder.
std::vector<CameraObservations> detectImageFolders(const std::string& root, const BoardSpec& board,
                                                   std::vector<RejectedView>& rejected);

}  // namespace mocap
