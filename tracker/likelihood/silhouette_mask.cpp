// Bit-packed silhouette masks with per-word running counts.
#include "tracker/likelihood/silhouette_mask.h"

#include <stdexcept>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace mocap {

SilhouetteMask::SilhouetteMask(const cv::Mat& binary) {
  if (binary.type() != CV_8UC1)
    throw std::invalid_argument("silhouette mask must be 8-bit single channel, got type " +
                                std::to_string(binary.type()));
  width_ = binary.cols;
  height_ = binary.rows;
  words_per_row_ = width_ / 64 + 1;
  words_.assign(static_cast<std::size_t>(height_) * words_per_row_, Word{});
  for (int y = 0; y < height_; ++y) {
    const uint8_t* src = binary.ptr<uint8_t>(y);
    Word* row = words_.data() + static_cast<std::size_t>(y) * words_per_row_;
    int x = 0;
#if defined(__SSE2__)
    // 16 pixels per step: a byte compare and its sign mask give their bits directly (built once
    // per frame and camera, for the live pipeline too).
    const __m128i zero = _mm_setzero_si128();
    for (; x + 16 <= width_; x += 16) {
      const __m128i pixels = _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + x));
      const unsigned off = static_cast<unsigned>(_mm_movemask_epi8(_mm_cmpeq_epi8(pixels, zero)));
      const unsigned on = ~off & 0xffffu;
      row[x >> 6].bits |= uint64_t{on} << (x & 63);
    }
#endif
    for (; x < width_; ++x)
      if (src[x]) row[x >> 6].bits |= uint64_t{1} << (x & 63);
    uint32_t running = 0;
    for (int w = 0; w < words_per_row_; ++w) {
      row[w].before = running;
      running += static_cast<uint32_t>(std::popcount(row[w].bits));
      row[w].bits <<= 1;
    }
  }
}

long SilhouetteMask::total() const {
  long sum = 0;
  for (int y = 0; y < height_; ++y) sum += count(y, 0, width_);
  return sum;
}

cv::Mat SilhouetteMask::toMat() const { return toMat(cv::Rect(0, 0, width_, height_)); }

cv::Mat SilhouetteMask::toMat(const cv::Rect& roi) const {
  if ((roi & cv::Rect(0, 0, width_, height_)) != roi)
    throw std::invalid_argument("silhouette mask: region outside the mask");
  cv::Mat out(roi.size(), CV_8UC1);
  for (int y = 0; y < roi.height; ++y) {
    const Word* words = words_.data() + static_cast<std::size_t>(roi.y + y) * words_per_row_;
    uint8_t* dst = out.ptr<uint8_t>(y);
    for (int i = 0; i < roi.width; ++i) {
      const int x = roi.x + i;
      // Pixel 64 w + i is bit i + 1 of word w, but for i = 63, which only the counts hold.
      const bool set = (x & 63) != 63 ? (words[x >> 6].bits >> ((x & 63) + 1)) & 1
                                      : count(roi.y + y, x, x + 1) != 0;
      dst[i] = set ? 255 : 0;
    }
  }
  return out;
}

}  // namespace mocap
