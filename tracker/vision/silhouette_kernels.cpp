// Row kernels of the silhouette extractor: universal intrinsics for the per-byte work, plain loops
// the compiler vectorizes for the morphology. Rounding is round-half-even as in OpenCV (cvRound,
// v_round), and float expressions keep OpenCV's and the plain loops' order of operations.
#include "tracker/vision/silhouette_kernels.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

namespace mocap::silhouette_kernels {

namespace {

using cv::v_float32x4;
using cv::v_int32x4;
using cv::v_uint16x8;
using cv::v_uint32x4;
using cv::v_uint8x16;

// Each byte times `scale`, rounded and saturated: convertTo's v_fma(x, scale, 0) is the product.
// The signed packs are exact while scale < kFastScaleLimit (products below 2^15).
constexpr float kFastScaleLimit = 128.0f;
v_uint8x16 scaleBytes(const v_uint8x16& bytes, const v_float32x4& scale) {
  v_uint16x8 low, high;
  cv::v_expand(bytes, low, high);
  v_uint32x4 q0, q1, q2, q3;
  cv::v_expand(low, q0, q1);
  cv::v_expand(high, q2, q3);
  auto scaled = [&](const v_uint32x4& v) {
    return cv::v_round(cv::v_cvt_f32(cv::v_reinterpret_as_s32(v)) * scale);
  };
  return cv::v_pack_u(cv::v_pack(scaled(q0), scaled(q1)), cv::v_pack(scaled(q2), scaled(q3)));
}

// Nonzero bytes lie outside [lower, upper] (saturating differences).
v_uint8x16 outside(const v_uint8x16& value, const uint8_t* lower, const uint8_t* upper) {
  return (cv::v_load(lower) - value) | (value - cv::v_load(upper));
}

// Brackets the normalized bytes without rounding floats: with m = round(256 * scale) (scale <
// kFastScaleLimit, so m * 255 / 256 < 2^15), q = floor(in * m / 256) is within in / 512 < 0.5 of
// in * scale, so the normalized byte is q or q + 1 (both saturated). It is surely in range if
// lower <= q and q + 1 <= upper.
struct Bracket {
  v_uint16x8 m;
  explicit Bracket(float scale)
      : m(cv::v_setall_u16(static_cast<uint16_t>(std::lround(256.0 * scale)))) {}
  // Nonzero bytes are those the bracket cannot show to be in range.
  v_uint8x16 unsure(const uint8_t* in, const uint8_t* lower, const uint8_t* upper) const {
    // A zero byte below each input byte: in * 256 per 16-bit lane.
    v_uint8x16 low, high;
    cv::v_zip(cv::v_setzero_u8(), cv::v_load(in), low, high);
    const v_uint8x16 q =
        cv::v_pack_u(cv::v_reinterpret_as_s16(cv::v_mul_hi(cv::v_reinterpret_as_u16(low), m)),
                     cv::v_reinterpret_as_s16(cv::v_mul_hi(cv::v_reinterpret_as_u16(high), m)));
    // Saturating arithmetic: nonzero where q < lower or q + 1 > upper.
    return (cv::v_load(lower) - q) | ((q + cv::v_setall_u8(1)) - cv::v_load(upper));
  }
};

// One pixel the vectors did not cover.
bool insidePixel(const uint8_t* in, const uint8_t* lower, const uint8_t* upper, int channels,
                 float scale) {
  for (int c = 0; c < channels; ++c) {
    const uint8_t value = cv::saturate_cast<uint8_t>(in[c] * scale);
    if (value < lower[c] || value > upper[c]) return false;
  }
  return true;
}

// testRow for a known channel count, so the per-channel loops unroll.
template <int kChannels>
void testRowOf(const uint8_t* in, const uint8_t* lower, const uint8_t* upper, int cols, float scale,
               uint8_t* unchanged) {
  const v_float32x4 vscale = cv::v_setall_f32(scale);
  const v_uint8x16 zero = cv::v_setzero_u8(), all = cv::v_setall_u8(255);
  const Bracket bracket(scale);
  const auto testPixels = [&](int x) {  // x .. x + 15
    const int first = kChannels * x;
    v_uint8x16 unsure = zero;
    for (int part = 0; part < kChannels; ++part)
      unsure = unsure | bracket.unsure(in + first + 16 * part, lower + first + 16 * part,
                                       upper + first + 16 * part);
    if (!cv::v_check_any(unsure != zero)) {
      cv::v_store(unchanged + x, all);
      return;
    }
    // Exactly: the normalized bytes outside their range.
    v_uint8x16 out_of_range[kChannels];
    for (int part = 0; part < kChannels; ++part) {
      const int offset = first + 16 * part;
      out_of_range[part] =
          outside(scaleBytes(cv::v_load(in + offset), vscale), lower + offset, upper + offset);
    }
    if constexpr (kChannels == 1) {
      cv::v_store(unchanged + x, out_of_range[0] == zero);
    } else {
      uint8_t bytes[48];
      for (int part = 0; part < 3; ++part) cv::v_store(bytes + 16 * part, out_of_range[part]);
      v_uint8x16 b, g, r;
      cv::v_load_deinterleave(bytes, b, g, r);
      cv::v_store(unchanged + x, (b | g | r) == zero);
    }
  };
  int x = 0;
  for (; x + 16 <= cols; x += 16) testPixels(x);
  if (x < cols) testPixels(cols - 16);  // the last 16, overlapping: the same values again
}

}  // namespace

void normalizeRow(const uint8_t* in, int count, float scale, uint8_t* normalized) {
  const v_float32x4 vscale = cv::v_setall_f32(scale);
  int i = 0;
  if (scale < kFastScaleLimit)
    for (; i + 16 <= count; i += 16)
      cv::v_store(normalized + i, scaleBytes(cv::v_load(in + i), vscale));
  for (; i < count; ++i) normalized[i] = cv::saturate_cast<uint8_t>(in[i] * scale);
}

void testRow(const uint8_t* in, const uint8_t* lower, const uint8_t* upper, int cols, int channels,
             float scale, uint8_t* unchanged) {
  // A gain near zero, or a row under 16 pixels: every pixel takes the scalar path.
  if (!(scale < kFastScaleLimit) || cols < 16) {
    for (int x = 0; x < cols; ++x)
      unchanged[x] = insidePixel(in + channels * x, lower + channels * x, upper + channels * x,
                                 channels, scale)
                         ? 255
                         : 0;
    return;
  }
  if (channels == 1)
    testRowOf<1>(in, lower, upper, cols, scale, unchanged);
  else
    testRowOf<3>(in, lower, upper, cols, scale, unchanged);
}

void boundsRow(const float* mean, const float* margin, int count, uint8_t* lower, uint8_t* upper) {
  int i = 0;
  for (; i + 16 <= count; i += 16) {
    v_int32x4 below[4], above[4];
    for (int part = 0; part < 4; ++part) {
      const v_float32x4 mu = cv::v_load(mean + i + 4 * part);
      const v_float32x4 width = cv::v_load(margin + i + 4 * part);
      below[part] = cv::v_round(mu - width);
      above[part] = cv::v_round(mu + width);
    }
    // Signed packs to 16 bits, then unsigned to 8: both clamp to [0, 255] as saturate_cast does,
    // and SSE2 has a single instruction for each (not for the unsigned 32 to 16 bit pack).
    cv::v_store(lower + i,
                cv::v_pack_u(cv::v_pack(below[0], below[1]), cv::v_pack(below[2], below[3])));
    cv::v_store(upper + i,
                cv::v_pack_u(cv::v_pack(above[0], above[1]), cv::v_pack(above[2], above[3])));
  }
  for (; i < count; ++i) {
    lower[i] = cv::saturate_cast<uint8_t>(mean[i] - margin[i]);
    upper[i] = cv::saturate_cast<uint8_t>(mean[i] + margin[i]);
  }
}

void groupColourRow(const float* bgr, int cols, float* grouped) {
  int x = 0;
  const v_float32x4 one = cv::v_setall_f32(1.0f);
  for (; x + 4 <= cols; x += 4, grouped += kColourGroupFloats) {
    v_float32x4 b, g, r;
    cv::v_load_deinterleave(bgr + 3 * x, b, g, r);
    cv::v_store(grouped, b);
    cv::v_store(grouped + 4, g);
    cv::v_store(grouped + 8, r);
    cv::v_store(grouped + 12, one / (b * b + g * g + r * r + one));
  }
  if (x == cols) return;
  std::fill(grouped, grouped + kColourGroupFloats, 0.0f);
  for (int lane = 0; x < cols; ++x, ++lane) {
    const float* mu = bgr + 3 * x;
    for (int c = 0; c < 3; ++c) grouped[4 * c + lane] = mu[c];
    grouped[12 + lane] = 1.0f / (mu[0] * mu[0] + mu[1] * mu[1] + mu[2] * mu[2] + 1.0f);
  }
}

namespace {

// Normalized values as floats: saturate(round_half_even(raw * scale)), as normalizeRow gives them.
// The products are finite and non-negative while scale < kFastScaleLimit, where clamping to 255
// before rounding is saturating after it.
v_float32x4 normalizedFloats(const v_float32x4& raw, const v_float32x4& scale) {
  return cv::v_cvt_f32(cv::v_round(cv::v_min(raw * scale, cv::v_setall_f32(255.0f))));
}

// The four groups of four floats of 16 bytes.
void bytesToFloats(const v_uint8x16& bytes, v_float32x4 out[4]) {
  v_uint16x8 low, high;
  cv::v_expand(bytes, low, high);
  v_uint32x4 a, c;
  cv::v_expand(low, a, c);
  out[0] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(a));
  out[1] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(c));
  cv::v_expand(high, a, c);
  out[2] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(a));
  out[3] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(c));
}

// The colour test of one pixel, as colorRatioRow's vectors do it.
bool keepsColour(const float pixel[3], const float* mu, float sigma, const ShadowBand& band) {
  const float b = pixel[0], g = pixel[1], r = pixel[2];
  const float mb = mu[0], mg = mu[1], mr = mu[2];
  const float energy = mb * mb + mg * mg + mr * mr + 1.0f;
  const float ratio = (b * mb + g * mg + r * mr) / energy;
  const float db = b - ratio * mb, dg = g - ratio * mg, dr = r - ratio * mr;
  const float tolerance =
      band.chroma_sigmas * sigma + band.chroma_ratio * ratio * std::sqrt(energy);
  return db * db + dg * dg + dr * dr <= tolerance * tolerance;
}

}  // namespace

void ratioRow(const uint8_t* in, float scale, const float* inverse_mean, int cols,
              const ShadowBand& band, float* ratio, float* ratio_squared, uint8_t* in_band) {
  const v_float32x4 vscale = cv::v_setall_f32(scale), min_ratio = cv::v_setall_f32(band.min_ratio),
                    max_ratio = cv::v_setall_f32(band.max_ratio);
  int x = 0;
  if (scale < kFastScaleLimit) {
    for (; x + 16 <= cols; x += 16) {
      v_float32x4 value[4];
      bytesToFloats(cv::v_load(in + x), value);
      cv::v_int32x4 inside[4];
      for (int k = 0; k < 4; ++k) {
        const int at = x + 4 * k;
        const v_float32x4 q = normalizedFloats(value[k], vscale) * cv::v_load(inverse_mean + at);
        cv::v_store(ratio + at, q);
        cv::v_store(ratio_squared + at, q * q);
        inside[k] = cv::v_reinterpret_as_s32((q >= min_ratio) & (q <= max_ratio));
      }
      // All-ones lanes stay all ones through the signed packs.
      cv::v_store(reinterpret_cast<int8_t*>(in_band + x),
                  cv::v_pack(cv::v_pack(inside[0], inside[1]), cv::v_pack(inside[2], inside[3])));
    }
  }
  for (; x < cols; ++x) {
    ratio[x] = cv::saturate_cast<uint8_t>(in[x] * scale) * inverse_mean[x];
    ratio_squared[x] = ratio[x] * ratio[x];
    in_band[x] = ratio[x] >= band.min_ratio && ratio[x] <= band.max_ratio ? 255 : 0;
  }
}

void colorRatioRow(const uint8_t* in, float scale, const float* grouped, const float* sigma,
                   const uint8_t* unchanged, int cols, const ShadowBand& band, float* ratio,
                   float* ratio_squared, uint8_t* in_band) {
  const v_float32x4 vscale = cv::v_setall_f32(scale), one = cv::v_setall_f32(1.0f),
                    min_ratio = cv::v_setall_f32(band.min_ratio),
                    max_ratio = cv::v_setall_f32(band.max_ratio),
                    chroma_sigmas = cv::v_setall_f32(band.chroma_sigmas),
                    chroma_ratio = cv::v_setall_f32(band.chroma_ratio);
  int x = 0;
  if (scale < kFastScaleLimit) {
    for (; x + 16 <= cols; x += 16) {
      v_uint8x16 b8, g8, r8;
      cv::v_load_deinterleave(in + 3 * x, b8, g8, r8);
      v_float32x4 b[4], g[4], r[4];
      bytesToFloats(b8, b);
      bytesToFloats(g8, g);
      bytesToFloats(r8, r);
      // All ones where the pixel changed, per lane of each group of four (signed expansions keep
      // all ones).
      cv::v_int32x4 changed[4];
      {
        cv::v_int16x8 low, high;
        cv::v_expand(cv::v_reinterpret_as_s8(cv::v_load(unchanged + x) == cv::v_setzero_u8()), low,
                     high);
        cv::v_expand(low, changed[0], changed[1]);
        cv::v_expand(high, changed[2], changed[3]);
      }
      cv::v_int32x4 inside[4];
      for (int k = 0; k < 4; ++k) {
        const int at = x + 4 * k;
        const float* group = grouped + kColourGroupFloats * (at / 4);
        const v_float32x4 nb = normalizedFloats(b[k], vscale), ng = normalizedFloats(g[k], vscale),
                          nr = normalizedFloats(r[k], vscale);
        const v_float32x4 mb = cv::v_load(group), mg = cv::v_load(group + 4),
                          mr = cv::v_load(group + 8);
        const v_float32x4 dot = nb * mb + ng * mg + nr * mr;
        const v_float32x4 q = dot * cv::v_load(group + 12);
        cv::v_store(ratio + at, q);
        cv::v_store(ratio_squared + at, q * q);
        inside[k] = cv::v_reinterpret_as_s32((q >= min_ratio) & (q <= max_ratio)) & changed[k];
        if (!cv::v_check_any(inside[k])) continue;
        // keepsColour, lane by lane; its divisions and roots only where they decide.
        const v_float32x4 energy = mb * mb + mg * mg + mr * mr + one;
        const v_float32x4 own = dot / energy;
        const v_float32x4 db = nb - own * mb, dg = ng - own * mg, dr = nr - own * mr;
        const v_float32x4 tolerance =
            chroma_sigmas * cv::v_load(sigma + at) + chroma_ratio * own * cv::v_sqrt(energy);
        inside[k] = inside[k] &
                    cv::v_reinterpret_as_s32(db * db + dg * dg + dr * dr <= tolerance * tolerance);
      }
      cv::v_store(reinterpret_cast<int8_t*>(in_band + x),
                  cv::v_pack(cv::v_pack(inside[0], inside[1]), cv::v_pack(inside[2], inside[3])));
    }
  }
  for (; x < cols; ++x) {
    float pixel[3], mu[3];
    for (int c = 0; c < 3; ++c) {
      pixel[c] = cv::saturate_cast<uint8_t>(in[3 * x + c] * scale);
      mu[c] = groupedColourAt(grouped, x, c);
    }
    ratio[x] =
        (pixel[0] * mu[0] + pixel[1] * mu[1] + pixel[2] * mu[2]) * groupedColourAt(grouped, x, 3);
    ratio_squared[x] = ratio[x] * ratio[x];
    in_band[x] = !unchanged[x] && ratio[x] >= band.min_ratio && ratio[x] <= band.max_ratio &&
                         keepsColour(pixel, mu, sigma[x], band)
                     ? 255
                     : 0;
  }
}

namespace {

// Sums of five neighbours along one row of floats, the edges reflected, in double.
void rowSums5(const float* in, int cols, double* sums) {
  const auto at = [&](int x) {
    return static_cast<double>(in[x < 0 ? -x : x >= cols ? 2 * cols - 2 - x : x]);
  };
  const auto edge = [&](int x) { sums[x] = at(x - 2) + at(x - 1) + at(x) + at(x + 1) + at(x + 2); };
  edge(0);
  edge(1);
  int x = 2;
#if CV_SIMD128_64F  // not on 32-bit ARM: the plain loop below does all pixels there
  for (; x + 4 <= cols - 2; x += 4) {  // four pixels: two vectors of two doubles
    const v_float32x4 first = cv::v_load(in + x - 2);
    cv::v_float64x2 low = cv::v_cvt_f64(first), high = cv::v_cvt_f64_high(first);
    for (int dx = -1; dx <= 2; ++dx) {
      const v_float32x4 values = cv::v_load(in + x + dx);
      low = low + cv::v_cvt_f64(values);
      high = high + cv::v_cvt_f64_high(values);
    }
    cv::v_store(sums + x, low);
    cv::v_store(sums + x + 2, high);
  }
#endif
  for (; x < cols; ++x) edge(x);
}

}  // namespace

void patchSums5x5(const cv::Mat& src, cv::Mat& dst, std::vector<double>& row_sums) {
  CV_Assert(src.type() == CV_32FC1);
  const int rows = src.rows, cols = src.cols;
  if (rows < 5 || cols < 5) {
    cv::boxFilter(src, dst, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
    return;
  }
  dst.create(src.size(), CV_32FC1);
  // Five rows of row sums (row r in slot (r + 5) % 5, from r = -2) and the running column sums.
  row_sums.resize(static_cast<std::size_t>(6) * cols);
  const auto slot = [&](int r) {
    return row_sums.data() + static_cast<std::ptrdiff_t>((r + 5) % 5) * cols;
  };
  const auto rowSums = [&](int r) {
    const int source = r < 0 ? -r : r >= rows ? 2 * rows - 2 - r : r;
    rowSums5(src.ptr<float>(source), cols, slot(r));
  };
  double* total = row_sums.data() + static_cast<std::ptrdiff_t>(5) * cols;
  std::fill(total, total + cols, 0.0);
  for (int r = -2; r <= 1; ++r) {
    rowSums(r);
    const double* add = slot(r);
    for (int x = 0; x < cols; ++x) total[x] += add[x];
  }
  for (int y = 0; y < rows; ++y) {
    rowSums(y + 2);
    const double* add = slot(y + 2);
    const double* drop = slot(y - 2);
    float* out = dst.ptr<float>(y);
    int x = 0;
#if CV_SIMD128_64F
    for (; x + 4 <= cols; x += 4) {
      const cv::v_float64x2 low = cv::v_load(total + x) + cv::v_load(add + x);
      const cv::v_float64x2 high = cv::v_load(total + x + 2) + cv::v_load(add + x + 2);
      cv::v_store(out + x, cv::v_cvt_f32(low, high));
      cv::v_store(total + x, low - cv::v_load(drop + x));
      cv::v_store(total + x + 2, high - cv::v_load(drop + x + 2));
    }
#endif
    for (; x < cols; ++x) {
      const double sum = total[x] + add[x];
      out[x] = static_cast<float>(sum);
      total[x] = sum - drop[x];
    }
  }
}

void fitPlanes(const float* const rows[5], const float* const squares[5], int x0, float mean[4],
               float residual[4]) {
  // The plain loop's sums start at 0 and add q * dx per term: 0 + q is q, q * 0 adds a zero (at
  // most the sign of a zero sum_x changes, which its square drops), adding q * -1 is subtracting q
  // and q * 2 is q + q, all exactly; so the terms below are the plain loop's in its order.
  v_float32x4 sum, sum_sq, sum_x, sum_y;
  for (int dy = -2; dy <= 2; ++dy) {
    const float* ratio = rows[dy + 2] + x0;
    const float* square = squares[dy + 2] + x0;
    const v_float32x4 q0 = cv::v_load(ratio - 2), q1 = cv::v_load(ratio - 1),
                      q2 = cv::v_load(ratio), q3 = cv::v_load(ratio + 1),
                      q4 = cv::v_load(ratio + 2);
    const v_float32x4 row = (((q0 + q1) + q2) + q3) + q4;
    const v_float32x4 first_x = q0 + q0;  // q0 * 2, negated below
    if (dy == -2) {
      sum_sq = cv::v_load(square - 2);
      sum_x = cv::v_setzero_f32() - first_x;
      sum = row;
      sum_y = row * cv::v_setall_f32(-2.0f);
    } else {
      sum_sq = sum_sq + cv::v_load(square - 2);
      sum_x = sum_x - first_x;
      sum = sum + row;
      sum_y = sum_y + row * cv::v_setall_f32(static_cast<float>(dy));
    }
    sum_sq = sum_sq + cv::v_load(square - 1);
    sum_sq = sum_sq + cv::v_load(square);
    sum_sq = sum_sq + cv::v_load(square + 1);
    sum_sq = sum_sq + cv::v_load(square + 2);
    sum_x = ((sum_x - q1) + q3) + (q4 + q4);
  }
  // Least-squares plane over the symmetric 5x5 grid: sum(dx^2) = sum(dy^2) = 50.
  const v_float32x4 patch_mean = sum / cv::v_setall_f32(25.0f);
  cv::v_store(mean, patch_mean);
  cv::v_store(residual, sum_sq - sum * patch_mean -
                            (sum_x * sum_x + sum_y * sum_y) / cv::v_setall_f32(50.0f));
}

namespace {

// Zeroes words [first, end) of rows [top, bottom) of rows of `words` words.
void clearBox(std::vector<uint64_t>& bits, int words, int top, int bottom, int first, int end) {
  if (first >= end) return;
  for (int y = top; y < bottom; ++y) {
    uint64_t* row = bits.data() + static_cast<std::size_t>(y) * words;
    std::fill(row + first, row + end, 0);
  }
}

}  // namespace

cv::Rect PackedMask::box() const {
  if (empty()) return {};
  const int left = 64 * first_word, right = std::min(cols, 64 * end_word);
  return {left, top, right - left, bottom - top};
}

void PackedMask::shrinkBox() {
  int new_top = bottom, new_bottom = top, new_first = end_word, new_end = first_word;
  for (int y = top; y < bottom; ++y) {
    const uint64_t* in = row(y);
    for (int w = first_word; w < end_word; ++w) {
      if (in[w] == 0) continue;
      new_top = std::min(new_top, y);
      new_bottom = y + 1;
      new_first = std::min(new_first, w);
      new_end = std::max(new_end, w + 1);
    }
  }
  if (new_top >= new_bottom) new_top = new_bottom = new_first = new_end = 0;
  top = new_top;
  bottom = new_bottom;
  first_word = new_first;
  end_word = new_end;
}

void pack(const cv::Mat& src, PackedMask& dst) {
  CV_Assert(src.type() == CV_8UC1);
  const int words = (src.cols + 63) / 64;
  if (dst.rows == src.rows && dst.cols == src.cols &&
      dst.bits.size() == static_cast<std::size_t>(src.rows) * words) {
    // Zero but in its box already (the last frame's): clearing that is enough.
    clearBox(dst.bits, words, dst.top, dst.bottom, dst.first_word, dst.end_word);
  } else {
    dst.rows = src.rows;
    dst.cols = src.cols;
    dst.words = words;
    dst.bits.assign(static_cast<std::size_t>(dst.rows) * dst.words, 0);
  }
  const v_uint8x16 zero = cv::v_setzero_u8();
  for (int y = 0; y < src.rows; ++y) {
    const uint8_t* in = src.ptr<uint8_t>(y);
    uint64_t* out = dst.row(y);
    int x = 0;
    // A word at a time; most words of most frames are zero, and stay so.
    for (; x + 64 <= src.cols; x += 64) {
      const v_uint8x16 set[4] = {cv::v_load(in + x) != zero, cv::v_load(in + x + 16) != zero,
                                 cv::v_load(in + x + 32) != zero, cv::v_load(in + x + 48) != zero};
      if (!cv::v_check_any(set[0] | set[1] | set[2] | set[3])) continue;
      uint64_t word = 0;
      for (int part = 0; part < 4; ++part)
        word |= static_cast<uint64_t>(cv::v_signmask(set[part])) << (16 * part);
      out[x / 64] = word;
    }
    for (; x + 16 <= src.cols; x += 16) {
      const auto set = static_cast<uint64_t>(cv::v_signmask(cv::v_load(in + x) != zero));
      out[x / 64] |= set << (x % 64);
    }
    for (; x < src.cols; ++x)
      if (in[x]) out[x / 64] |= uint64_t{1} << (x % 64);
  }
  dst.top = dst.first_word = 0;
  dst.bottom = dst.rows;
  dst.end_word = dst.words;
  dst.shrinkBox();
}

void unpackBox(const PackedMask& src, cv::Mat& dst) {
  dst.create(src.rows, src.cols, CV_8UC1);
  // Eight pixels at a time: the 8 bytes of each 8-bit pattern.
  static const auto patterns = [] {
    std::array<uint64_t, 256> table{};
    for (int bits = 0; bits < 256; ++bits)
      for (int i = 0; i < 8; ++i)
        if (bits & (1 << i)) table[static_cast<std::size_t>(bits)] |= uint64_t{0xff} << (8 * i);
    return table;
  }();
  const cv::Rect box = src.box();
  for (int y = box.y; y < box.br().y; ++y) {
    const uint64_t* in = src.row(y);
    uint8_t* out = dst.ptr<uint8_t>(y);
    int x = box.x;
    for (; x + 8 <= box.br().x; x += 8) {
      const uint64_t bytes = patterns[(in[x / 64] >> (x % 64)) & 0xff];
      std::memcpy(out + x, &bytes, sizeof bytes);
    }
    for (; x < box.br().x; ++x) out[x] = (in[x / 64] >> (x % 64)) & 1 ? 255 : 0;
  }
}

RunMorphology::RunMorphology(const cv::Mat& kernel) {
  if (kernel.type() != CV_8UC1 || kernel.rows != kernel.cols || kernel.rows % 2 == 0 ||
      kernel.rows >= 128)
    throw std::invalid_argument("morphology kernel: expected an odd square 8-bit mask under 128");
  const int radius = kernel.rows / 2;
  for (int y = 0; y < kernel.rows; ++y) {
    const uint8_t* row = kernel.ptr<uint8_t>(y);
    const int half = radius - static_cast<int>(std::find(row, row + kernel.cols, 1) - row);
    if (half < 0) throw std::invalid_argument("morphology kernel: a row is empty");
    for (int x = 0; x < kernel.cols; ++x)
      if ((row[x] != 0) != (x >= radius - half && x <= radius + half))
        throw std::invalid_argument("morphology kernel: a row is not one centred run");
    half_widths_.push_back(half);
    auto found = std::find(distinct_widths_.begin(), distinct_widths_.end(), half);
    if (half > 0 && found == distinct_widths_.end())
      found = distinct_widths_.insert(distinct_widths_.end(), half);
    width_index_.push_back(half > 0 ? static_cast<int>(found - distinct_widths_.begin()) : -1);
  }
  windows_.resize(distinct_widths_.size());
}

void RunMorphology::horizontalWindows(const PackedMask& mask, bool erode, int first_word,
                                      int end_word) {
  const int words = mask.words;
  // Outside the image: the identity of the operation, as OpenCV's default morphology border.
  const uint64_t border = erode ? ~uint64_t{0} : 0;
  const int tail = mask.cols % 64;
  const uint64_t outside_tail = tail == 0 ? 0 : ~((uint64_t{1} << tail) - 1);
  line_.assign(static_cast<std::size_t>(words + 2), border);
  for (auto& window : windows_) window.resize(mask.bits.size());
  // Zero rows have zero windows: they are never read.
  for (int y = mask.top; y < mask.bottom; ++y) {
    if (!nonzero_rows_[static_cast<std::size_t>(y)]) continue;
    std::copy(mask.row(y), mask.row(y) + words, line_.begin() + 1);
    line_[static_cast<std::size_t>(words)] |= outside_tail & border;
    for (std::size_t i = 0; i < distinct_widths_.size(); ++i) {
      const int half = distinct_widths_[i];
      uint64_t* out = windows_[i].data() + static_cast<std::size_t>(y) * words;
      for (int w = first_word; w < end_word; ++w) {
        const uint64_t* at = line_.data() + w + 1;  // at[-1] and at[1] are the neighbour words
        uint64_t combined = at[0];
        for (int shift = 1; shift <= half; ++shift) {
          // Pixel x + shift and x - shift, each reaching into the neighbour word (shift < 64).
          const uint64_t right = (at[0] >> shift) | (at[1] << (64 - shift));
          const uint64_t left = (at[0] << shift) | (at[-1] >> (64 - shift));
          combined = erode ? (combined & right & left) : (combined | right | left);
        }
        out[w] = combined;
      }
    }
  }
}

void RunMorphology::apply(PackedMask& mask, bool erode) {
  CV_Assert(!empty());
  const int words = mask.words, radius = static_cast<int>(half_widths_.size() / 2);
  // An erosion keeps within the box; a dilation reaches `radius` rows and (radius < 64) one word
  // further. Either leaves an empty mask empty.
  int top = mask.top, bottom = mask.bottom, first = mask.first_word, end = mask.end_word;
  if (!erode && !mask.empty()) {
    top = std::max(0, top - radius);
    bottom = std::min(mask.rows, bottom + radius);
    first = std::max(0, first - 1);
    end = std::min(words, end + 1);
  }
  // result_ holds what the last call swapped out: zero but in its box.
  if (result_.size() == mask.bits.size() && spare_words_ == words)
    clearBox(result_, words, spare_top_, spare_bottom_, spare_first_, spare_end_);
  else
    result_.assign(mask.bits.size(), 0);
  spare_words_ = words;
  spare_top_ = mask.top;
  spare_bottom_ = mask.bottom;
  spare_first_ = mask.first_word;
  spare_end_ = mask.end_word;
  if (mask.empty()) {
    mask.bits.swap(result_);
    return;
  }
  // Frames are mostly empty rows, which need no work.
  nonzero_rows_.assign(static_cast<std::size_t>(mask.rows), 0);
  for (int y = mask.top; y < mask.bottom; ++y) {
    const uint64_t* in = mask.row(y);
    uint64_t any = 0;
    for (int w = mask.first_word; w < mask.end_word; ++w) any |= in[w];
    nonzero_rows_[static_cast<std::size_t>(y)] = any != 0;
  }
  horizontalWindows(mask, erode, first, end);
  const int tail = mask.cols % 64;
  const uint64_t inside_tail = tail == 0 ? ~uint64_t{0} : (uint64_t{1} << tail) - 1;
  for (int y = top; y < bottom; ++y) {
    uint64_t* out = result_.data() + static_cast<std::size_t>(y) * words;
    std::fill(out + first, out + end, erode ? ~uint64_t{0} : 0);
    // Rows outside the image are the border: they leave the result as it is. Zero rows inside it
    // make an erosion zero and leave a dilation unchanged.
    for (int k = std::max(0, radius - y); k <= std::min(2 * radius, mask.rows - 1 - y + radius);
         ++k) {
      const int sy = y + k - radius, index = width_index_[static_cast<std::size_t>(k)];
      if (!nonzero_rows_[static_cast<std::size_t>(sy)]) {
        if (!erode) continue;
        std::fill(out + first, out + end, 0);
        break;
      }
      const uint64_t* in = index < 0 ? mask.row(sy)
                                     : windows_[static_cast<std::size_t>(index)].data() +
                                           static_cast<std::size_t>(sy) * words;
      if (erode)
        for (int w = first; w < end; ++w) out[w] &= in[w];
      else
        for (int w = first; w < end; ++w) out[w] |= in[w];
    }
    out[words - 1] &= inside_tail;
  }
  mask.bits.swap(result_);
  mask.top = top;
  mask.bottom = bottom;
  mask.first_word = first;
  mask.end_word = end;
  mask.shrinkBox();
}

}  // namespace mocap::silhouette_kernels
