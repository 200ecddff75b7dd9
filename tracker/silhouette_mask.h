// A binary silhouette in the form the likelihood consumes: bit-packed rows with a running count per
// 64-pixel word, so the foreground pixels of any row interval are counted in O(1) (two popcounts)
// without touching the rest of the frame. 780x580 takes 120 KB, small enough to stay in cache.
#pragma once

#include <bit>
#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace mocap {

class SilhouetteMask {
 public:
  SilhouetteMask() = default;
  // `binary`: CV_8UC1, non-zero = foreground. Throws std::invalid_argument otherwise.
  explicit SilhouetteMask(const cv::Mat& binary);

  int width() const { return width_; }
  int height() const { return height_; }
  // Foreground pixels of row y in columns [x0, x1); requires 0 <= x0 <= x1 <= width, 0 <= y < height.
  int count(int y, int x0, int x1) const { return row(y).count(x0, x1); }

 private:
  struct Word {
    uint64_t bits = 0;     // bit i = pixel 64 * word + i
    uint32_t before = 0;   // foreground pixels of the row before this word
  };

 public:
  // One row, for callers that count several intervals of it: an endpoint shared by two intervals
  // is looked up once.
  class Row {
   public:
    // Foreground pixels in columns [0, x), 0 <= x <= width.
    int before(int x) const {
      const Word& w = words_[x >> 6];
      return static_cast<int>(w.before) + std::popcount(w.bits & ((uint64_t{1} << (x & 63)) - 1));
    }
    int count(int x0, int x1) const { return before(x1) - before(x0); }

   private:
    friend class SilhouetteMask;
    explicit Row(const Word* words) : words_(words) {}
    const Word* words_;
  };
  // Requires 0 <= y < height.
  Row row(int y) const { return Row(words_.data() + static_cast<std::size_t>(y) * words_per_row_); }
  // Foreground pixels in the whole mask.
  long total() const;
  // Back to an 8-bit 0/255 image.
  cv::Mat toMat() const;

 private:
  int width_ = 0;
  int height_ = 0;
  int words_per_row_ = 0;  // width / 64 + 1: column `width` has a word too
  std::vector<Word> words_;
};

}  // namespace mocap
