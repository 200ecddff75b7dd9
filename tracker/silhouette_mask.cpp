// Prefix-summed silhouette masks.
#include "tracker/silhouette_mask.h"

#include <stdexcept>
#include <string>

namespace mocap {

SilhouetteMask::SilhouetteMask(const cv::Mat& binary) {
  if (binary.type() != CV_8UC1)
    throw std::invalid_argument("silhouette mask must be 8-bit single channel, got type " +
                                std::to_string(binary.type()));
  if (binary.cols > 65535) throw std::invalid_argument("silhouette mask wider than 65535 pixels");
  width_ = binary.cols;
  height_ = binary.rows;
  prefix_.resize(static_cast<std::size_t>(height_) * (width_ + 1));
  for (int y = 0; y < height_; ++y) {
    const uint8_t* src = binary.ptr<uint8_t>(y);
    uint16_t* row = prefix_.data() + static_cast<std::size_t>(y) * (width_ + 1);
    uint16_t sum = 0;
    row[0] = 0;
    for (int x = 0; x < width_; ++x) {
      sum = static_cast<uint16_t>(sum + (src[x] != 0));
      row[x + 1] = sum;
    }
  }
}

long SilhouetteMask::total() const {
  long sum = 0;
  for (int y = 0; y < height_; ++y) sum += count(y, 0, width_);
  return sum;
}

cv::Mat SilhouetteMask::toMat() const {
  cv::Mat out(height_, width_, CV_8UC1);
  for (int y = 0; y < height_; ++y) {
    uint8_t* dst = out.ptr<uint8_t>(y);
    for (int x = 0; x < width_; ++x) dst[x] = count(y, x, x + 1) ? 255 : 0;
  }
  return out;
}

}  // namespace mocap
