// Turns a V4L2 buffer payload (YUYV, GREY, MJPEG) into the 8-bit gray or BGR image a Frame carries.
#pragma once

#include <cstdint>
#include <span>

#include <opencv2/core/mat.hpp>

#include "drivers/v4l2/v4l2_device.h"

namespace mocap {

// What the driver hands downstream: colour where the camera has it, or always gray (cheaper, and
// all silhouette extraction needs when the background model is gray).
enum class V4l2ImageOutput { kBgr, kGray };

struct ConvertedPayload {
  cv::Mat image;            // empty: the payload cannot be turned into an image at all
  bool incomplete = false;  // short payload or a JPEG without its end marker
};

// Never throws; the image owns its pixels, so the buffer can be requeued at once.
ConvertedPayload convertPayload(const NegotiatedFormat& format, std::span<const uint8_t> payload,
                                V4l2ImageOutput output);

}  // namespace mocap
