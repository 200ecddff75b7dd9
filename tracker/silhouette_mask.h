// A binary silhouette in the form the likelihood consumes: per-row prefix sums, so the foreground
// pixels of any row interval are counted in O(1) without touching the rest of the frame.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace mocap {

class SilhouetteMask {
 public:
  SilhouetteMask() = default;
  // `binary`: CV_8UC1, non-zero = foreground. Throws std::invalid_argument otherwise or if wider
  // than 65535 pixels.
  explicit SilhouetteMask(const cv::Mat& binary);

  int width() const { return width_; }
  int height() const { return height_; }
  // Foreground pixels of row y in columns [x0, x1); requires 0 <= x0 <= x1 <= width, 0 <= y < height.
  int count(int y, int x0, int x1) const {
    const uint16_t* row = prefix_.data() + static_cast<std::size_t>(y) * (width_ + 1);
    return row[x1] - row[x0];
  }
  // Foreground pixels in the whole mask.
  long total() const;
  // Back to an 8-bit 0/255 image.
  cv::Mat toMat() const;

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<uint16_t> prefix_;  // (width + 1) entries per row, prefix_[y][0] == 0
};

}  // namespace mocap
