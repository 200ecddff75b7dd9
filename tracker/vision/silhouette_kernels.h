// Row kernels of the silhouette extractor, written with OpenCV's 128-bit universal intrinsics
// (SSE2 on any x86-64, NEON on ARM) so the shipped build needs no CPU flags. Each kernel gives
// bit for bit the values of the OpenCV calls it replaces (named at each one), and none of them
// uses OpenCV's parallel_for_: the extractor runs on its caller's thread only.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace mocap::silhouette_kernels {

// `count` bytes: normalized = saturate(round_half_even(in * scale)) (cv::Mat::convertTo's float
// path).
void normalizeRow(const uint8_t* in, int count, float scale, uint8_t* normalized);

// One row of `cols` pixels of `channels` (1 or 3) interleaved bytes: unchanged[x] = 255 if every
// channel of the normalized pixel (as normalizeRow) lies in [lower, upper], else 0 (cv::inRange).
// Most pixels are decided by a cheaper 16-bit product that brackets the normalized value.
void testRow(const uint8_t* in, const uint8_t* lower, const uint8_t* upper, int cols, int channels,
             float scale, uint8_t* unchanged);

// lower = saturate(round_half_even(mean - margin)), upper the same of mean + margin, over `count`
// values (cv::subtract or cv::add, then convertTo CV_8U).
void boundsRow(const float* mean, const float* margin, int count, uint8_t* lower, uint8_t* upper);

// The background's colour as colorRatioRow reads it: per group of four pixels (from the first),
// their blue, green and red means and their inverse energy 1 / (b^2 + g^2 + r^2 + 1) (summed in
// that order, as a plain loop), four floats each. A group is one cache line and each quantity one
// vector: no shuffles, one line to load per four pixels. The floats of a partial last group's
// missing pixels are zero.
constexpr int kColourGroupFloats = 16;  // per group of four pixels
inline int groupedColourFloats(int cols) { return kColourGroupFloats * ((cols + 3) / 4); }
// Of pixel x: quantity 0, 1, 2 (the blue, green, red mean) or 3 (the inverse energy).
inline float groupedColourAt(const float* grouped, int x, int quantity) {
  return grouped[kColourGroupFloats * (x / 4) + 4 * quantity + x % 4];
}
// `cols` BGR floats into groupedColourFloats(cols) floats.
void groupColourRow(const float* bgr, int cols, float* grouped);

// Which pixels may be shadows before any plane fit: those whose own ratio frame / background lies
// in [min_ratio, max_ratio] and, in colour, that keep the background's colour.
struct ShadowBand {
  float min_ratio, max_ratio, chroma_sigmas, chroma_ratio;
};

// From the frame's bytes `in` and the gain's `scale`: ratio = normalized * inverse_mean (the gray
// shadow test's frame / background), with normalized as normalizeRow gives it, and its square;
// in_band = 255 where the ratio lies in the band, else 0.
void ratioRow(const uint8_t* in, float scale, const float* inverse_mean, int cols,
              const ShadowBand& band, float* ratio, float* ratio_squared, uint8_t* in_band);

// The colour shadow test's ratio, from the frame's BGR bytes `in` normalized as normalizeRow does
// (b, g, r): the frame's component along the background colour over the background's, ratio = (b *
// mb + g * mg + r * mr) * inverse_energy, where `grouped` holds the background's means mb, mg, mr
// and inverse_energy 1 / (mb^2 + mg^2 + mr^2 + 1) as groupColourRow gives them (its first pixel
// starting a group); and its square. The sums run in that order, as a plain loop does. in_band =
// 255 where the pixel changed (unchanged is 0), its ratio lies in the band and it keeps the
// background's colour, else 0: with c = (b * mb + g * mg + r * mr) / (mb^2 + mg^2 + mr^2 + 1),
// |pixel - c * mean|^2 <= (chroma_sigmas * sigma + chroma_ratio * c * |mean|)^2, each operation
// that of the plain scalar expression, in its order (and only computed for the pixels it decides).
void colorRatioRow(const uint8_t* in, float scale, const float* grouped, const float* sigma,
                   const uint8_t* unchanged, int cols, const ShadowBand& band, float* ratio,
                   float* ratio_squared, uint8_t* in_band);

// The least-squares plane of the ratio over the 5x5 patches centred on pixels x0 .. x0+3 of the
// middle row: `rows` and `squares` point at the five rows' ratios and squared ratios, readable from
// x0 - 2 to x0 + 5. Per pixel, `mean` is the patch's mean ratio and `residual` what the plane
// leaves; the summation order is that of a plain loop over dy then dx, lane by lane.
void fitPlanes(const float* const rows[5], const float* const squares[5], int x0, float mean[4],
               float residual[4]);

// The sum over each 5x5 patch of a one-channel float image, equal to cv::boxFilter(src, dst,
// CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false) with its default border (reflected, the edge
// pixel not repeated): in double, each row's five neighbours summed left to right, then per column
// a running sum down the image that adds the row sums two rows below a pixel, is rounded to float
// as its output, and drops the row sums two rows above it. `row_sums` keeps its buffers between
// calls. Images under 5 pixels wide or high go to cv::boxFilter.
void patchSums5x5(const cv::Mat& src, cv::Mat& dst, std::vector<double>& row_sums);

// A binary image, one bit per pixel (bit x % 64 of word x / 64 of its row), for the morphology.
// Every set bit lies in rows [top, bottom) and words [first_word, end_word) (the box); the bits
// outside it are zero, so work on a frame with a person in part of it stays within that part.
struct PackedMask {
  int rows = 0, cols = 0, words = 0;  // words per row
  int top = 0, bottom = 0, first_word = 0, end_word = 0;
  std::vector<uint64_t> bits;
  uint64_t* row(int y) { return bits.data() + static_cast<std::size_t>(y) * words; }
  const uint64_t* row(int y) const { return bits.data() + static_cast<std::size_t>(y) * words; }
  bool empty() const { return top >= bottom || first_word >= end_word; }
  // The box's pixels, clipped to the image.
  cv::Rect box() const;
  // Narrows the box to the rows and words that hold a set bit.
  void shrinkBox();
};

// Nonzero bytes of `src` (8-bit, one channel) become set bits; `dst` is resized to match (one of
// that size already keeps its buffer and clears its box) and its box is the set bits' rows and
// words.
void pack(const cv::Mat& src, PackedMask& dst);
// The box's pixels: set bits become 255, the others 0, in `dst` (the mask's size; allocated if
// needed). Pixels outside the box are left as they are.
void unpackBox(const PackedMask& src, cv::Mat& dst);

// Erosion and dilation of a packed mask by a structuring element whose rows are centred runs
// shorter than 128 pixels (a disk from cv::getStructuringElement(MORPH_ELLIPSE)), equal to
// cv::erode and cv::dilate with their default border (pixels outside the image never change the
// result). 64 pixels per operation, over the mask's box only (a dilation widens it by the
// element's radius); buffers are kept between calls.
class RunMorphology {
 public:
  RunMorphology() = default;
  explicit RunMorphology(const cv::Mat& kernel);
  bool empty() const { return half_widths_.empty(); }

  void erode(PackedMask& mask) { apply(mask, true); }
  void dilate(PackedMask& mask) { apply(mask, false); }

 private:
  void apply(PackedMask& mask, bool erode);
  void horizontalWindows(const PackedMask& mask, bool erode, int first_word, int end_word);

  std::vector<int> half_widths_;      // per kernel row: the run is [-h, h] around the centre column
  std::vector<int> distinct_widths_;  // the nonzero half widths
  std::vector<int> width_index_;  // per kernel row: its window in windows_, -1 for the row itself
  std::vector<std::vector<uint64_t>>
      windows_;                        // per distinct width: each row's AND or OR over the run
  std::vector<uint64_t> line_;         // one row with a border word on both sides
  std::vector<uint8_t> nonzero_rows_;  // per row of the mask: any bit set
  std::vector<uint64_t> result_;
  // Of result_ (rows of spare_words_ words): zero outside these rows and words.
  int spare_words_ = 0, spare_top_ = 0, spare_bottom_ = 0, spare_first_ = 0, spare_end_ = 0;
};

}  // namespace mocap::silhouette_kernels
