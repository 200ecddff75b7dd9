// Silhouette extraction: gain estimate (the median by a radix selection); one pass over the rows
// that range-tests (vectorized, a bracket of the normalized value, exact where it cannot decide)
// and runs the shadow test on the changed pixels only (ratios with their band and colour tests by
// blocks of 16 pixels around them; then a plane fit four pixels at a time, joined to textured
// shadows by connectivity); morphology on bit-packed rows and contour-based blob and hole cleanup,
// both within the box the opening leaves; slow adaptation, and one pass over the rows for all that
// derives from the mean.
#include "tracker/vision/silhouette_extractor.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

namespace mocap {

namespace {

void checkOptions(const SilhouetteOptions& o) {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("silhouette options: ") + what);
  };
  require(o.threshold_sigmas > 0 && o.min_difference >= 0, "thresholds must be positive");
  require(o.shadow_texture_sigmas > 0 && o.shadow_texture_contrast >= 0,
          "shadow_texture_sigmas must be > 0 and shadow_texture_contrast >= 0");
  require(
      o.shadow_min_ratio > 0 && o.shadow_min_ratio < o.shadow_max_ratio && o.shadow_max_ratio <= 1,
      "shadow ratio band must satisfy 0 < min < max <= 1");
  require(o.open_radius >= 0 && o.close_radius >= 0 && o.open_radius < 64 && o.close_radius < 64,
          "morphology radii must be in [0, 63]");
  require(o.min_blob_fraction >= 0 && o.max_hole_fraction >= 0, "blob/hole sizes must be >= 0");
  require(o.gain_sample_step >= 1, "gain_sample_step must be >= 1");
  require(o.adapt_interval >= 1 && o.adapt_rate >= 0 && o.adapt_rate <= 1,
          "adapt_interval >= 1 and adapt_rate in [0, 1]");
}

// First column at or after x that changed (or `end`): most of a frame is background, so test eight
// pixels per step.
int skipUnchanged(const uint8_t* unchanged, int x, int end) {
  while (x + 8 <= end) {
    uint64_t word;
    std::memcpy(&word, unchanged + x, sizeof word);
    if (word != ~uint64_t{0}) break;
    x += 8;
  }
  while (x < end && unchanged[x]) ++x;
  return x;
}

silhouette_kernels::RunMorphology diskMorphology(int radius) {
  if (radius == 0) return {};
  return silhouette_kernels::RunMorphology(
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1)));
}

// Per pixel of a BGR float image: sqrt(b^2 + g^2 + r^2), the scale of its colour.
cv::Mat colorMagnitude(const cv::Mat& bgr) {
  cv::Mat magnitude(bgr.size(), CV_32FC1);
  for (int y = 0; y < bgr.rows; ++y) {
    const float* mu = bgr.ptr<float>(y);
    float* out = magnitude.ptr<float>(y);
    for (int x = 0; x < bgr.cols; ++x, mu += 3)
      out[x] = std::sqrt(mu[0] * mu[0] + mu[1] * mu[1] + mu[2] * mu[2]);
  }
  return magnitude;
}

// Gain samples of one row (see estimateGain): frame / background brightness at columns first,
// first + step, ... of the pixels that were background last frame, with `expected` the background's
// brightness at each. The bytes sum exactly as integers.
template <int kChannels>
void gainSamples(const uint8_t* in, const float* expected, const uint8_t* foreground,
                 const uint8_t* shadow, int first, int cols, int step,
                 std::vector<float>& samples) {
  for (int x = first, i = 0; x < cols; x += step, ++i) {
    if (foreground[x] | shadow[x]) continue;
    int observed = in[kChannels * x];
    for (int c = 1; c < kChannels; ++c) observed += in[kChannels * x + c];
    // Dark and saturated pixels do not scale with the light.
    if (expected[i] < 20.0f * kChannels || static_cast<float>(observed) > 250.0f * kChannels)
      continue;
    samples.push_back(static_cast<float>(observed) / expected[i]);
  }
}

// The k-th smallest (from 0) of finite non-negative floats: the value std::nth_element puts at k.
// Such floats order as their bit patterns do, so this selects by the top 11 bits, then the next
// 11, then the last 10, counting without branches (nth_element's comparisons mispredict).
float kthSmallest(const std::vector<float>& values, std::size_t k, std::vector<uint32_t>& counts) {
  uint32_t prefix = 0;  // the bits found so far, in place
  int known = 0;        // how many of the top bits those are
  for (const int width : {11, 11, 10}) {
    const int shift = 32 - known - width;
    counts.assign(std::size_t{1} << width, 0);
    const uint32_t digit_mask = (uint32_t{1} << width) - 1;
    for (const float value : values) {
      const uint32_t bits = std::bit_cast<uint32_t>(value);
      // Values outside the prefix found so far add 0 (known == 0: all match).
      const bool matches = known == 0 || (bits >> (32 - known)) == (prefix >> (32 - known));
      counts[(bits >> shift) & digit_mask] += matches ? 1 : 0;
    }
    uint32_t digit = 0;
    for (; k >= counts[digit]; ++digit) k -= counts[digit];
    prefix |= digit << shift;
    known += width;
  }
  return std::bit_cast<float>(prefix);
}

// Rows of the ratio ring: the plane fit reads three floats past the last column.
constexpr int kRatioRing = 5, kRatioPadding = 4;
constexpr int kRatioBlock = 16;  // pixels per block of ratios computed at once
constexpr int kCacheLine = 64;   // bytes, the unit of prefetching

}  // namespace

SilhouetteExtractor::SilhouetteExtractor(BackgroundModel background, SilhouetteOptions options)
    : options_(options) {
  checkOptions(options_);
  shadow_band_ = {options_.shadow_min_ratio, options_.shadow_max_ratio,
                  options_.shadow_chroma_sigmas, options_.shadow_chroma_ratio};
  open_ = diskMorphology(options_.open_radius);
  close_ = diskMorphology(options_.close_radius);
  setBackground(std::move(background));
}

void SilhouetteExtractor::setBackground(BackgroundModel background) {
  if (background.empty() || background.mean.depth() != CV_32F ||
      (background.channels() != 1 && background.channels() != 3) ||
      background.stddev.size() != background.size() ||
      background.stddev.type() != background.mean.type())
    throw std::invalid_argument(
        "background model: expected float mean and stddev of 1 or 3 "
        "channels and equal sizes");
  // Own copies: adapt() blends into the mean in place, and the caller's model (e.g. the one saved
  // as learned) may be shared with other readers.
  background_ = {background.mean.clone(), background.stddev.clone()};
  const cv::Rect frame(cv::Point(0, 0), background_.size());
  roi_ = options_.region_of_interest.empty() ? frame : (options_.region_of_interest & frame);
  if (roi_.empty()) throw std::invalid_argument("region of interest lies outside the frame");
  mean_view_ = background_.mean(roi_);

  const int channels = background_.channels();
  const cv::Mat stddev = background_.stddev(roi_);
  margin_ = cv::max(stddev * options_.threshold_sigmas, options_.min_difference);
  cv::Mat flat =
      stddev.clone().reshape(1, stddev.rows * stddev.cols);  // a region is not continuous
  cv::reduce(flat, pixel_sigma_, 1, cv::REDUCE_AVG);
  pixel_sigma_ = cv::max(pixel_sigma_.reshape(1, stddev.rows), 1.0f);  // floor: quantization
  // Shadow test: how far the background's texture stands out of the noise over each 5x5 patch once
  // a plane is removed (a shadow scales that texture; a flat patch cannot show it). Gray: of the
  // mean; BGR: of its magnitude, the scale of the ratio's colour direction. Learned once:
  // adaptation follows slow light changes, which barely change the texture.
  cv::Mat base = background_.mean(roi_);
  if (channels == 3) base = colorMagnitude(base);
  const cv::Mat ones = cv::Mat::ones(5, 1, CV_32F);
  const cv::Mat ramp = (cv::Mat_<float>(5, 1) << -2, -1, 0, 1, 2);
  cv::Mat sum, sum_sq, sum_x, sum_y, noise;
  cv::boxFilter(base, sum, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
  cv::sqrBoxFilter(base, sum_sq, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
  cv::sepFilter2D(base, sum_x, CV_32F, ramp, ones);
  cv::sepFilter2D(base, sum_y, CV_32F, ones, ramp);
  cv::sqrBoxFilter(pixel_sigma_, noise, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
  texture_ = sum_sq - sum.mul(sum) / 25.0f - (sum_x.mul(sum_x) + sum_y.mul(sum_y)) / 50.0f;
  cv::divide(cv::max(texture_, 0.0f), noise, texture_);
  weak_shadow_ = cv::Mat::zeros(stddev.size(), CV_8UC1);
  scratch_.ratio_rows = cv::Mat::zeros(kRatioRing, stddev.cols + kRatioPadding, CV_32FC1);
  scratch_.ratio_squares = cv::Mat::zeros(kRatioRing, stddev.cols + kRatioPadding, CV_32FC1);
  scratch_.fit_columns.reserve(static_cast<std::size_t>(stddev.cols));
  scratch_.ratio_blocks = (stddev.cols + kRatioBlock - 1) / kRatioBlock;
  scratch_.ratio_done.assign(static_cast<std::size_t>(kRatioRing * scratch_.ratio_blocks), -1);
  scratch_.first_row_number = 0;

  const cv::Size size = roi_.size();
  lower_.create(size, CV_8UC(channels));
  upper_.create(size, CV_8UC(channels));
  scratch_.normalized.create(size, CV_8UC(channels));
  scratch_.band_rows.create(kRatioRing, stddev.cols, CV_8UC1);
  // Columns whose 5x5 patch lies inside the region: those that may take the plane fit.
  inner_columns_ = cv::Mat::zeros(1, stddev.cols, CV_8UC1);
  if (stddev.cols > 4) inner_columns_.colRange(2, stddev.cols - 2).setTo(255);
  scratch_.unchanged.create(size, CV_8UC1);
  scratch_.candidates.create(size, CV_8UC1);
  scratch_.written_rows.assign(static_cast<std::size_t>(size.height), 1);  // all to clear
  scratch_.cleaned.create(size, CV_8UC1);
  shadow_.create(size, CV_8UC1);
  foreground_.create(background_.size(), CV_8UC1);
  foreground_.setTo(0);
  drawn_ = {};
  shadow_.setTo(0);
  scratch_.gain_samples.reserve(
      static_cast<std::size_t>(size.area() / options_.gain_sample_step + 1));
  gain_ = 1.0;
  frame_count_ = 0;
  rebuildBounds();
}

void SilhouetteExtractor::rebuildBounds() {
  // Everything derived from the mean, row by row while the row is in the caches:
  // - the unchanged range, mean -+ margin rounded and clipped to 8 bits;
  // - for the shadow test, what turns the frame into the ratio frame / background (gray: 1 /
  //   background; BGR: 1 / the background's energy), and the noise of that ratio, (sigma /
  //   background)^2 or sigma^2 / energy per pixel, each value as the OpenCV calls first written
  //   (cv::add, divide, multiply) gave it; summed over each 5x5 patch after the loop;
  // - at the gain's sample points, the background's brightness: the sum of the channel means,
  //   added in order (from 0, as the first plain loop did: a zero's sign aside, which no sample
  //   keeps).
  const cv::Mat& mean = mean_view_;
  const int channels = mean.channels(), step = options_.gain_sample_step;
  if (channels == 1)
    inverse_mean_.create(mean.size(), CV_32FC1);
  else
    grouped_bgr_.create(mean.rows, silhouette_kernels::groupedColourFloats(mean.cols), CV_32FC1);
  bound_scratch_.create(mean.size(), CV_32FC1);
  gain_expected_.create((mean.rows - step / 2 + step - 1) / step,
                        (mean.cols - step / 2 + step - 1) / step, CV_32FC1);
  for (int y = 0; y < mean.rows; ++y) {
    const float* mu = mean.ptr<float>(y);
    silhouette_kernels::boundsRow(mu, margin_.ptr<float>(y), mean.cols * channels,
                                  lower_.ptr<uint8_t>(y), upper_.ptr<uint8_t>(y));
    const float* sigma = pixel_sigma_.ptr<float>(y);
    float* noise = bound_scratch_.ptr<float>(y);
    if (channels == 1) {
      float* inverse = inverse_mean_.ptr<float>(y);
      for (int x = 0; x < mean.cols; ++x) {
        inverse[x] = 1.0f / (mu[x] + 1.0f);  // as cv::divide: no case for a zero
        const float relative = sigma[x] * inverse[x];
        noise[x] = relative * relative;
      }
    } else {
      float* grouped = grouped_bgr_.ptr<float>(y);
      silhouette_kernels::groupColourRow(mu, mean.cols, grouped);
      int x = 0;
      for (; x + 4 <= mean.cols; x += 4) {  // a group's inverse energies are its last vector
        const cv::v_float32x4 deviation = cv::v_load(sigma + x);
        const float* inverse = grouped + silhouette_kernels::kColourGroupFloats * (x / 4) + 12;
        cv::v_store(noise + x, deviation * deviation * cv::v_load(inverse));
      }
      for (; x < mean.cols; ++x)
        noise[x] = sigma[x] * sigma[x] * silhouette_kernels::groupedColourAt(grouped, x, 3);
    }
    if (y < step / 2 || (y - step / 2) % step != 0) continue;
    float* expected = gain_expected_.ptr<float>((y - step / 2) / step);
    for (int j = 0; j < gain_expected_.cols; ++j) {
      const float* pixel = mu + channels * (step / 2 + j * step);
      float sum = pixel[0];
      for (int c = 1; c < channels; ++c) sum += pixel[c];
      expected[j] = sum;
    }
  }
  silhouette_kernels::patchSums5x5(bound_scratch_, ratio_noise_, scratch_.patch_sums);
}

void SilhouetteExtractor::estimateGain(const cv::Mat& frame) {
  // Median of frame/background brightness over pixels that were background last frame: robust to
  // the person and shadows, and cheap on a sparse grid.
  const cv::Mat& mean = mean_view_;
  const int channels = mean.channels();
  const int step = options_.gain_sample_step;
  const cv::Mat previous = foreground_(roi_);
  std::vector<float>& samples = scratch_.gain_samples;
  samples.clear();
  // The frame is new to the caches and its sampled rows lie far apart, too far for the hardware's
  // prefetch: each row asks for the next one's cache lines, or every sample waits on memory.
  const int row_bytes = mean.cols * channels;
  for (int y = step / 2, i = 0; y < mean.rows; y += step, ++i) {
    const uint8_t* in = frame.ptr<uint8_t>(y);
    if (y + step < mean.rows) {
      const uint8_t* next = frame.ptr<uint8_t>(y + step);
      for (int at = 0; at < row_bytes; at += kCacheLine) __builtin_prefetch(next + at);
    }
    const float* expected = gain_expected_.ptr<float>(i);
    const uint8_t* fg = previous.ptr<uint8_t>(y);
    const uint8_t* sh = shadow_.ptr<uint8_t>(y);
    if (channels == 1)
      gainSamples<1>(in, expected, fg, sh, step / 2, mean.cols, step, samples);
    else
      gainSamples<3>(in, expected, fg, sh, step / 2, mean.cols, step, samples);
  }
  if (samples.size() < 32) return;  // too little background seen: keep the last gain
  gain_ = kthSmallest(samples, samples.size() / 2, scratch_.histogram);
}

void SilhouetteExtractor::classify(const cv::Mat& region, float scale) {
  // Row y is classified once rows y-2 .. y+2 are tested: the plane fit reads them from a ring.
  const int rows = roi_.height, cols = roi_.width, channels = region.channels();
  scratch_.weak_pixels.clear();
  scratch_.region = region;
  scratch_.scale = scale;
  scratch_.first_row_number += rows;  // no row of an earlier frame has these numbers
  for (int y = 0; y < rows + 2; ++y) {
    if (y < rows)
      silhouette_kernels::testRow(region.ptr<uint8_t>(y), lower_.ptr<uint8_t>(y),
                                  upper_.ptr<uint8_t>(y), cols, channels, scale,
                                  scratch_.unchanged.ptr<uint8_t>(y));
    if (y >= 2) classifyRow(y - 2);
  }
  if (!scratch_.weak_pixels.empty()) resolveWeakShadows();
}

void SilhouetteExtractor::ensureRatios(int first_row, int last_row, int begin, int end) {
  // Ratios are needed only around changed pixels: most rows of most frames have none, and most of
  // a row with some lies outside them. They are computed by blocks of kRatioBlock pixels, runs of
  // blocks not yet done in one call.
  const int first = std::max(begin, 0) / kRatioBlock;
  const int last = (std::min(end, roi_.width) - 1) / kRatioBlock;
  for (int y = first_row; y <= last_row; ++y) {
    int64_t* done = scratch_.ratio_done.data() +
                    static_cast<std::ptrdiff_t>(y % kRatioRing) * scratch_.ratio_blocks;
    const int64_t row_number = scratch_.first_row_number + y;
    for (int block = first; block <= last; ++block) {
      if (done[block] == row_number) continue;
      int run_end = block + 1;
      while (run_end <= last && done[run_end] != row_number) ++run_end;
      std::fill(done + block, done + run_end, row_number);
      computeRatios(y, block * kRatioBlock, std::min(run_end * kRatioBlock, roi_.width));
      block = run_end;  // done, or past the last
    }
  }
}

void SilhouetteExtractor::computeRatios(int y, int from, int to) {
  const int channels = background_.channels(), slot = y % kRatioRing;
  const uint8_t* in = scratch_.region.ptr<uint8_t>(y) + channels * from;
  float* ratio = scratch_.ratio_rows.ptr<float>(slot) + from;
  float* ratio_squared = scratch_.ratio_squares.ptr<float>(slot) + from;
  uint8_t* in_band = scratch_.band_rows.ptr<uint8_t>(slot) + from;
  if (channels == 1) {
    silhouette_kernels::ratioRow(in, scratch_.scale, inverse_mean_.ptr<float>(y) + from, to - from,
                                 shadow_band_, ratio, ratio_squared, in_band);
  } else {
    static_assert(kRatioBlock % 4 == 0, "a block starts a group of groupColourRow");
    const float* grouped =
        grouped_bgr_.ptr<float>(y) + silhouette_kernels::kColourGroupFloats * (from / 4);
    silhouette_kernels::colorRatioRow(in, scratch_.scale, grouped,
                                      pixel_sigma_.ptr<float>(y) + from,
                                      scratch_.unchanged.ptr<uint8_t>(y) + from, to - from,
                                      shadow_band_, ratio, ratio_squared, in_band);
  }
}

void SilhouetteExtractor::classifyRow(int y) {
  const SilhouetteOptions& o = options_;
  const float noise_scale = o.shadow_texture_sigmas * o.shadow_texture_sigmas;
  const int rows = roi_.height, cols = roi_.width;
  const uint8_t* same = scratch_.unchanged.ptr<uint8_t>(y);
  uint8_t* candidate = scratch_.candidates.ptr<uint8_t>(y);
  uint8_t* shadow = shadow_.ptr<uint8_t>(y);
  // Only rows with a changed pixel are ever written: most rows of most frames stay zero.
  uint8_t& written = scratch_.written_rows[static_cast<std::size_t>(y)];
  if (written) {
    std::memset(candidate, 0, static_cast<std::size_t>(cols));
    std::memset(shadow, 0, static_cast<std::size_t>(cols));
    written = 0;
  }
  const int first_changed = skipUnchanged(same, 0, cols);
  if (first_changed == cols) return;
  written = 1;
  // A shadow scales the background by a factor that varies smoothly (a soft edge is a ramp), so
  // over the 5x5 patch the ratio frame/background fits a plane up to the noise. A person brings
  // their own shading, stripes and edges and ignores the background's texture: the plane leaves
  // more than the learned noise (flat on flat stays ambiguous). Changed pixels whose own ratio is
  // in the shadow band (and, in colour, that keep the background's colour) take the fit; the
  // others are the person's. Colour alone is not enough: grey clothes over a grey floor keep it.
  const bool fits_row = o.suppress_shadows && y > 1 && y < rows - 2;
  const uint8_t* in_band = scratch_.band_rows.ptr<uint8_t>(y % kRatioRing);
  std::vector<int>& fit = scratch_.fit_columns;
  fit.clear();
  // By blocks of kRatioBlock pixels: a changed pixel is a candidate unless it takes the fit; the
  // ratios (and in_band) of a block are computed if one of its changed pixels may take it, a run of
  // such blocks at a time (calls block by block cost a third of the work).
  static_assert(kRatioBlock == 16, "one vector of bytes per block");
  const cv::v_uint8x16 zero = cv::v_setzero_u8();
  const uint8_t* inner = inner_columns_.ptr<uint8_t>();
  const auto mayFit = [&](int at) {
    return (cv::v_load(same + at) == zero) & cv::v_load(inner + at);
  };
  int ratios_end = 0;  // the ratios of this row's blocks below it are computed
  int column = first_changed - first_changed % kRatioBlock;
  for (; column + kRatioBlock <= cols; column += kRatioBlock) {
    const cv::v_uint8x16 changed = cv::v_load(same + column) == zero;
    if (!cv::v_check_any(changed)) continue;
    cv::v_uint8x16 fits = zero;
    if (fits_row) {
      const cv::v_uint8x16 may_fit = changed & cv::v_load(inner + column);
      if (cv::v_check_any(may_fit)) {
        if (column >= ratios_end) {
          ratios_end = column + kRatioBlock;
          while (ratios_end + kRatioBlock <= cols && cv::v_check_any(mayFit(ratios_end)))
            ratios_end += kRatioBlock;
          ensureRatios(y, y, column, ratios_end);
        }
        fits = may_fit & cv::v_load(in_band + column);
      }
    }
    cv::v_store(candidate + column, changed & ~fits);
    for (auto bits = static_cast<unsigned>(cv::v_signmask(fits)); bits != 0; bits &= bits - 1)
      fit.push_back(column + std::countr_zero(bits));
  }
  for (; column < cols; ++column) {  // the last partial block
    if (same[column]) continue;
    const bool takes_fit = fits_row && inner[column];
    if (takes_fit) ensureRatios(y, y, column, column + 1);
    if (takes_fit && in_band[column])
      fit.push_back(column);
    else
      candidate[column] = 255;
  }
  if (fit.empty()) return;
  const float* rows_ratio[kRatioRing];
  const float* rows_square[kRatioRing];
  for (int dy = -2; dy <= 2; ++dy) {
    rows_ratio[dy + 2] = scratch_.ratio_rows.ptr<float>((y + dy) % kRatioRing);
    rows_square[dy + 2] = scratch_.ratio_squares.ptr<float>((y + dy) % kRatioRing);
  }
  const float* noise_energy = ratio_noise_.ptr<float>(y);
  const float* texture = texture_.ptr<float>(y);
  uint8_t* weak = weak_shadow_.ptr<uint8_t>(y);
  int ready_end = 0;  // ratios of all five rows are computed for the columns below it
  for (std::size_t i = 0; i < fit.size();) {
    const int x0 = fit[i];
    // fitPlanes reads two columns left of a group of four and two right of it: for a run of fitted
    // pixels each within a block's width of the one before, that is this range (what lies between
    // two of them is too narrow to hold a block none of their groups reads).
    if (x0 + 6 > ready_end) {
      std::size_t reach = i;
      while (reach + 1 < fit.size() && fit[reach + 1] < fit[reach] + kRatioBlock) ++reach;
      ensureRatios(y - 2, y + 2, x0 - 2, fit[reach] + 6);
      ready_end = ((fit[reach] + 5) / kRatioBlock + 1) * kRatioBlock;
    }
    float mean[4], residual[4];
    silhouette_kernels::fitPlanes(rows_ratio, rows_square, x0, mean, residual);
    for (; i < fit.size() && fit[i] < x0 + 4; ++i) {
      const int x = fit[i];
      const float ratio = mean[x - x0];
      if (ratio < o.shadow_min_ratio || ratio > o.shadow_max_ratio ||
          !(residual[x - x0] <= noise_scale * noise_energy[x])) {
        candidate[x] = 255;
      } else if (ratio * ratio * texture[x] >= o.shadow_texture_contrast) {
        shadow[x] = 255;
      } else {
        weak[x] = 255;  // decided by resolveWeakShadows from what it is connected to
        scratch_.weak_pixels.push_back(static_cast<std::ptrdiff_t>(y) * cols + x);
      }
    }
  }
}

void SilhouetteExtractor::resolveWeakShadows() {
  // A smooth dark patch over a flat background fits a scaled background as well as a shadow does.
  // It is a shadow if it joins (8-connected, through weak or confident shadow pixels) a shadow that
  // showed the background's texture, else part of the person (a person's smooth clothing is ringed
  // by edges that fail the fit). Along any such path the last weak pixel before the first
  // confident one touches it: a flood through weak pixels, from those touching a confident one,
  // reaches exactly the weak pixels of such components. Weak pixels take the plane fit, so lie two
  // pixels or more inside the frame: their neighbours need no bounds check, and one offset into
  // the continuous masks names a pixel in each.
  constexpr uint8_t kReached = 1;  // a weak pixel (255) found to be a shadow
  const std::ptrdiff_t width = weak_shadow_.cols;
  const std::ptrdiff_t neighbours[8] = {-width - 1, -width, -width + 1, -1,
                                        1,          width,  width + 1,  width - 1};
  uint8_t* const weak = weak_shadow_.data;
  uint8_t* const sure = shadow_.data;
  uint8_t* const candidate = scratch_.candidates.data;
  const std::vector<std::ptrdiff_t>& weak_pixels = scratch_.weak_pixels;
  std::vector<std::ptrdiff_t>& stack = scratch_.flood_stack;
  stack.clear();
  for (const std::ptrdiff_t at : weak_pixels) {
    const uint8_t* around = sure + at;
    if (!(around[-width - 1] | around[-width] | around[-width + 1] | around[-1] | around[0] |
          around[1] | around[width - 1] | around[width] | around[width + 1]))
      continue;
    weak[at] = kReached;
    stack.push_back(at);
  }
  while (!stack.empty()) {
    const std::ptrdiff_t at = stack.back();
    stack.pop_back();
    for (const std::ptrdiff_t offset : neighbours) {
      if (weak[at + offset] != 255) continue;
      weak[at + offset] = kReached;
      stack.push_back(at + offset);
    }
  }
  for (const std::ptrdiff_t at : weak_pixels) {
    (weak[at] == kReached ? sure : candidate)[at] = 255;
    weak[at] = 0;  // ready for the next frame
  }
}

void SilhouetteExtractor::cleanup() {
  // Opening removes speckle, closing bridges gaps; each is an erosion and a dilation. The opening
  // leaves the noise of the frame's empty parts behind: from then on only the box around what is
  // left is touched.
  const cv::Mat* source = &scratch_.candidates;
  cv::Rect box(cv::Point(0, 0), roi_.size());
  if (!open_.empty() || !close_.empty()) {
    silhouette_kernels::pack(scratch_.candidates, scratch_.packed);
    if (!open_.empty()) {
      open_.erode(scratch_.packed);
      open_.dilate(scratch_.packed);
    }
    if (!close_.empty()) {
      close_.dilate(scratch_.packed);
      close_.erode(scratch_.packed);
    }
    silhouette_kernels::unpackBox(scratch_.packed, scratch_.cleaned);
    source = &scratch_.cleaned;
    box = scratch_.packed.box();
  }
  std::vector<std::vector<cv::Point>>& contours = scratch_.contours;
  std::vector<cv::Vec4i>& hierarchy = scratch_.hierarchy;
  contours.clear();
  hierarchy.clear();
  // The contours of the box alone are those of the whole image (it is zero around the box), found
  // in the same order.
  if (!box.empty())
    cv::findContours((*source)(box), contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE,
                     box.tl());

  cv::Mat out = foreground_(roi_);
  out(drawn_).setTo(0);  // every pixel set last frame lies in the box it was drawn in
  drawn_ = box;
  const double image_area = static_cast<double>(roi_.area());
  const double min_blob = options_.min_blob_fraction * image_area;
  const double max_hole = options_.max_hole_fraction * image_area;
  // RETR_CCOMP: top-level contours are outer boundaries, their children the holes in them.
  for (int i = 0; i >= 0 && i < static_cast<int>(contours.size()); i = hierarchy[i][0]) {
    if (cv::contourArea(contours[i]) < min_blob) continue;
    cv::drawContours(out, contours, i, 255, cv::FILLED);
    for (int hole = hierarchy[i][2]; hole >= 0; hole = hierarchy[hole][0]) {
      if (cv::contourArea(contours[hole]) <= max_hole) continue;
      cv::drawContours(out, contours, hole, 0, cv::FILLED);
      cv::drawContours(out, contours, hole, 255, 1);  // the hole's rim is foreground
    }
  }
}

void SilhouetteExtractor::adapt() {
  // Only pixels whose every channel matched the background and that are not inside a silhouette:
  // a person standing still, their shadow, or a slow-moving object never leak into the model.
  const cv::Mat& region = scratch_.region;
  const int count = region.cols * region.channels();
  for (int y = 0; y < region.rows; ++y)
    silhouette_kernels::normalizeRow(region.ptr<uint8_t>(y), count, scratch_.scale,
                                     scratch_.normalized.ptr<uint8_t>(y));
  cv::subtract(scratch_.unchanged, foreground_(roi_), scratch_.cleaned);  // free scratch by now
  cv::accumulateWeighted(scratch_.normalized, mean_view_, options_.adapt_rate, scratch_.cleaned);
  rebuildBounds();
}

bool SilhouetteExtractor::extract(const cv::Mat& frame) {
  if (frame.size() != background_.size() || frame.type() != CV_8UC(background_.channels())) {
    error_ = "frame is " + std::to_string(frame.cols) + "x" + std::to_string(frame.rows) +
             " with " + std::to_string(frame.channels()) + " channel(s) of depth " +
             std::to_string(frame.depth()) + ", background is " +
             std::to_string(background_.size().width) + "x" +
             std::to_string(background_.size().height) + " 8-bit with " +
             std::to_string(background_.channels()) + " channel(s)";
    return false;
  }
  error_.clear();
  const cv::Mat region = frame(roi_);
  if (options_.compensate_gain) estimateGain(region);
  // convertTo's scale: the float nearest 1 / gain.
  const float scale = static_cast<float>(1.0 / gain_);
  classify(region, scale);
  cleanup();
  if (options_.adaptive && ++frame_count_ % options_.adapt_interval == 0) adapt();
  if (options_.build_silhouette_mask) silhouette_ = SilhouetteMask(foreground_);
  return true;
}

}  // namespace mocap
