// The unit every camera driver produces and the synchronizer consumes: one image of one camera.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include <opencv2/core/mat.hpp>

namespace mocap {

struct Frame {
  int camera = 0;              // index of the camera in the configured camera list
  uint64_t sequence = 0;       // per-camera frame counter (the device's own where it has one)
  int64_t timestamp_ns = 0;    // CLOCK_MONOTONIC ns; each driver states which event it marks
  uint32_t dropped_before = 0; // frames known lost between the previous delivered frame and this one
  bool corrupt = false;        // the device flagged the payload as damaged (delivered anyway)
  cv::Mat image;               // CV_8UC1 gray or CV_8UC3 BGR
};

// Called on the driver's own thread; must not block for long (copy or hand off, then return).
using FrameSink = std::function<void(Frame&&)>;

}  // namespace mocap
