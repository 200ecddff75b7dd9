// Bit-packed silhouette masks with per-word running counts.
#include "tracker/silhouette_mask.h"

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

cv::Mat SilhouetteMask::toMat() const {
  cv::Mat out(height_, width_, CV_8UC1);
  for (int y = 0; y < height_; ++y) {
    uint8_t* dst = out.ptr<uint8_t>(y);
    for (int x = 0; x < width_; ++x) dst[x] = count(y, x, x + 1) ? 255 : 0;
  }
  return out;
}

}  // namespace mocap
