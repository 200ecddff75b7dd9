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
  // Foreground pixels of row y in columns [x0, x1); requires 0 <= x0 <= x1 <= width, 0 <= y <
  // height.
  int count(int y, int x0, int x1) const { return row(y).count(x0, x1); }

 private:
  struct Word {
    // Bit i + 1 = pixel 64 * word + i: shifted, so a lookup keeps the pixels below x with one
    // shift. Pixel 63 is never needed (x = 64 * word + 64 looks up the next word).
    uint64_t bits = 0;
    uint32_t before = 0;  // foreground pixels of the row before this word
  };

 public:
  // One row, for callers that count several intervals of it: an endpoint shared by two intervals
  // is looked up once.
  class Row {
   public:
    // Foreground pixels in columns [0, x), 0 <= x <= width.
    int before(int x) const {
      const Word& w = words_[x >> 6];
      // Shifted left by 63 - x % 64 (= ~x % 64), pixels x % 64 and above fall off the top.
      return static_cast<int>(w.before) + std::popcount(w.bits << (~x & 63));
    }
    int count(int x0, int x1) const { return before(x1) - before(x0); }
    // Moves to the row below, for loops walking rows in order (one add instead of a row lookup).
    void next() { words_ += stride_; }

   private:
    friend class SilhouetteMask;
    Row(const Word* words, int stride) : words_(words), stride_(stride) {}
    const Word* words_;
    int stride_;
  };
  // Requires 0 <= y <= height (y == height only as the end of a walk with Row::next).
  Row row(int y) const {
    return Row(words_.data() + static_cast<std::size_t>(y) * words_per_row_, words_per_row_);
  }
  // Foreground pixels in the whole mask.
  long total() const;
  // Back to an 8-bit 0/255 image, whole or the part in `roi` (within the mask).
  cv::Mat toMat() const;
  cv::Mat toMat(const cv::Rect& roi) const;

 private:
  int width_ = 0;
  int height_ = 0;
  int words_per_row_ = 0;  // width / 64 + 1: column `width` has a word too
  std::vector<Word> words_;
};

}  // namespace mocap
