// Silhouette extraction: gain estimate; one pass over the rows that range-tests (vectorized, a
// bracket of the normalized value, exact where it cannot decide) and runs the shadow test on the
// changed pixels only (BGR: the colour first; then a plane fit four pixels at a time, joined to
// textured shadows by connectivity); morphology on bit-packed rows and contour-based blob and hole
// cleanup, both within the box the opening leaves; slow adaptation.
#include "tracker/vision/silhouette_extractor.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

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

// First column at or after x that is not zero (or `end`): weak shadows are sparse in their box.
int skipZero(const uint8_t* row, int x, int end) {
  while (x + 8 <= end) {
    uint64_t word;
    std::memcpy(&word, row + x, sizeof word);
    if (word != 0) break;
    x += 8;
  }
  while (x < end && !row[x]) ++x;
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

// Per pixel of a BGR float image: 1 / (b^2 + g^2 + r^2 + 1), into `inverse` (reallocated if
// needed).
void inverseColorEnergy(const cv::Mat& bgr, cv::Mat& inverse) {
  inverse.create(bgr.size(), CV_32FC1);
  for (int y = 0; y < bgr.rows; ++y)
    silhouette_kernels::inverseEnergyRow(bgr.ptr<float>(y), bgr.cols, inverse.ptr<float>(y));
}

// Rows of the ratio ring: the plane fit reads three floats past the last column.
constexpr int kRatioRing = 5, kRatioPadding = 4;
constexpr int kRatioBlock = 16;  // pixels per block of ratios computed at once

}  // namespace

SilhouetteExtractor::SilhouetteExtractor(BackgroundModel background, SilhouetteOptions options)
    : options_(options) {
  checkOptions(options_);
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
  for (Scratch::RatioSlot& slot : scratch_.ratio_slots)
    slot.done.assign(
        static_cast<std::size_t>((stddev.cols + 64 * kRatioBlock - 1) / (64 * kRatioBlock)), 0);

  const cv::Size size = roi_.size();
  lower_.create(size, CV_8UC(channels));
  upper_.create(size, CV_8UC(channels));
  scratch_.normalized.create(size, CV_8UC(channels));
  scratch_.normalized_rows.create(kRatioRing, stddev.cols * channels, CV_8UC1);
  scratch_.unchanged.create(size, CV_8UC1);
  scratch_.candidates.create(size, CV_8UC1);
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
  // mean -+ margin, rounded and clipped to 8 bits.
  const cv::Mat& mean = mean_view_;
  const int count = mean.cols * mean.channels();
  for (int y = 0; y < mean.rows; ++y)
    silhouette_kernels::boundsRow(mean.ptr<float>(y), margin_.ptr<float>(y), count,
                                  lower_.ptr<uint8_t>(y), upper_.ptr<uint8_t>(y));
  // Shadow test: what turns the frame into the ratio frame / background (gray: 1 / background;
  // BGR: 1 / the background's energy), and the noise of that ratio summed over each 5x5 patch
  // (unnormalized box filter): (sigma / background)^2, or sigma^2 / energy, per pixel.
  if (background_.channels() == 1) {
    cv::add(mean, 1.0f, bound_scratch_);  // never divides by zero
    cv::divide(1.0f, bound_scratch_, inverse_mean_);
    cv::multiply(pixel_sigma_, inverse_mean_, bound_scratch_);
    cv::multiply(bound_scratch_, bound_scratch_, bound_scratch_);
  } else {
    inverseColorEnergy(mean, inverse_mean_);
    cv::multiply(pixel_sigma_, pixel_sigma_, bound_scratch_);
    cv::multiply(bound_scratch_, inverse_mean_, bound_scratch_);
  }
  cv::boxFilter(bound_scratch_, ratio_noise_, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
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
  for (int y = step / 2; y < mean.rows; y += step) {
    const uint8_t* in = frame.ptr<uint8_t>(y);
    const float* mu = mean.ptr<float>(y);
    const uint8_t* fg = previous.ptr<uint8_t>(y);
    const uint8_t* sh = shadow_.ptr<uint8_t>(y);
    for (int x = step / 2; x < mean.cols; x += step) {
      if (fg[x] || sh[x]) continue;
      float observed = 0, expected = 0;
      for (int c = 0; c < channels; ++c) {
        observed += in[x * channels + c];
        expected += mu[x * channels + c];
      }
      // Dark and saturated pixels do not scale with the light.
      if (expected < 20.0f * channels || observed > 250.0f * channels) continue;
      samples.push_back(observed / expected);
    }
  }
  if (samples.size() < 32) return;  // too little background seen: keep the last gain
  auto middle = samples.begin() + static_cast<std::ptrdiff_t>(samples.size() / 2);
  std::nth_element(samples.begin(), middle, samples.end());
  gain_ = *middle;
}

bool SilhouetteExtractor::keepsBackgroundColor(const uint8_t* in, const float* mu,
                                               float sigma) const {
  // A shadow dims the light but keeps the surface's colour: the pixel lies near the background
  // colour scaled by its brightness ratio.
  const SilhouetteOptions& o = options_;
  const float b = in[0], g = in[1], r = in[2];
  const float mb = mu[0], mg = mu[1], mr = mu[2];
  const float energy = mb * mb + mg * mg + mr * mr + 1.0f;
  const float ratio = (b * mb + g * mg + r * mr) / energy;
  const float db = b - ratio * mb, dg = g - ratio * mg, dr = r - ratio * mr;
  const float tolerance =
      o.shadow_chroma_sigmas * sigma + o.shadow_chroma_ratio * ratio * std::sqrt(energy);
  return db * db + dg * dg + dr * dr <= tolerance * tolerance;
}

void SilhouetteExtractor::classify(const cv::Mat& region, float scale) {
  // Row y is classified once rows y-2 .. y+2 are tested: the plane fit reads them from a ring.
  const int rows = roi_.height, cols = roi_.width, channels = region.channels();
  cv::Point weak_min(cols, rows), weak_max(-1, -1);
  scratch_.region = region;
  scratch_.scale = scale;
  for (Scratch::RatioSlot& slot : scratch_.ratio_slots) slot.row = -1;
  for (int y = 0; y < rows + 2; ++y) {
    if (y < rows)
      silhouette_kernels::testRow(region.ptr<uint8_t>(y), lower_.ptr<uint8_t>(y),
                                  upper_.ptr<uint8_t>(y), cols, channels, scale,
                                  scratch_.unchanged.ptr<uint8_t>(y));
    if (y >= 2) classifyRow(y - 2, weak_min, weak_max);
  }
  if (weak_max.x >= weak_min.x) resolveWeakShadows(cv::Rect(weak_min, weak_max + cv::Point(1, 1)));
}

void SilhouetteExtractor::ensureRatios(int y, int begin, int end) {
  // Ratios are needed only around changed pixels: most rows of most frames have none, and most of
  // a row with some lies outside them. They are computed by blocks of kRatioBlock pixels.
  begin = std::max(begin, 0);
  end = std::min(end, roi_.width);
  if (begin >= end) return;
  Scratch::RatioSlot& slot = scratch_.ratio_slots[static_cast<std::size_t>(y % kRatioRing)];
  if (slot.row != y) {
    slot.row = y;
    std::fill(slot.done.begin(), slot.done.end(), 0);
  }
  const auto compute = [&](int from, int to) {
    to = std::min(to, roi_.width);
    const int channels = background_.channels();
    const uint8_t* in = scratch_.region.ptr<uint8_t>(y);
    uint8_t* normalized = scratch_.normalized_rows.ptr<uint8_t>(y % kRatioRing);
    float* ratio = scratch_.ratio_rows.ptr<float>(y % kRatioRing);
    float* ratio_squared = scratch_.ratio_squares.ptr<float>(y % kRatioRing);
    const float* inverse = inverse_mean_.ptr<float>(y);
    const float* mean = mean_view_.ptr<float>(y);
    silhouette_kernels::normalizeRow(in + channels * from, channels * (to - from), scratch_.scale,
                                     normalized + channels * from);
    if (channels == 1)
      silhouette_kernels::ratioRow(normalized + from, inverse + from, to - from, ratio + from,
                                   ratio_squared + from);
    else
      silhouette_kernels::colorRatioRow(normalized + 3 * from, mean + 3 * from, inverse + from,
                                        to - from, ratio + from, ratio_squared + from);
  };
  // Runs of blocks not yet done, each in one call.
  const int last = (end - 1) / kRatioBlock;
  for (int block = begin / kRatioBlock; block <= last;) {
    uint64_t& word = slot.done[static_cast<std::size_t>(block / 64)];
    const uint64_t bit = uint64_t{1} << (block % 64);
    if (word & bit) {
      ++block;
      continue;
    }
    word |= bit;
    int run_end = block + 1;
    for (; run_end <= last; ++run_end) {
      uint64_t& next = slot.done[static_cast<std::size_t>(run_end / 64)];
      const uint64_t next_bit = uint64_t{1} << (run_end % 64);
      if (next & next_bit) break;
      next |= next_bit;
    }
    compute(block * kRatioBlock, run_end * kRatioBlock);
    block = run_end;
  }
}

void SilhouetteExtractor::classifyRow(int y, cv::Point& weak_min, cv::Point& weak_max) {
  const SilhouetteOptions& o = options_;
  const float noise_scale = o.shadow_texture_sigmas * o.shadow_texture_sigmas;
  const int rows = roi_.height, cols = roi_.width;
  const uint8_t* same = scratch_.unchanged.ptr<uint8_t>(y);
  uint8_t* candidate = scratch_.candidates.ptr<uint8_t>(y);
  uint8_t* shadow = shadow_.ptr<uint8_t>(y);
  std::memset(candidate, 0, static_cast<std::size_t>(cols));
  std::memset(shadow, 0, static_cast<std::size_t>(cols));
  const int first_changed = skipUnchanged(same, 0, cols);
  if (first_changed == cols) return;
  // A shadow scales the background by a factor that varies smoothly (a soft edge is a ramp), so
  // over the 5x5 patch the ratio frame/background fits a plane up to the noise. A person brings
  // their own shading, stripes and edges and ignores the background's texture: the plane leaves
  // more than the learned noise (flat on flat stays ambiguous). Changed pixels whose own ratio is
  // in the shadow band (and, in colour, that keep the background's colour) take the fit; the
  // others are the person's. Colour alone is not enough: grey clothes over a grey floor keep it.
  const bool fits_row = o.suppress_shadows && y > 1 && y < rows - 2;
  const float* centre = scratch_.ratio_rows.ptr<float>(y % kRatioRing);
  const bool color = background_.channels() == 3;
  // Normalized where the ratios are.
  const uint8_t* in = scratch_.normalized_rows.ptr<uint8_t>(y % kRatioRing);
  const float* mu = mean_view_.ptr<float>(y);
  const float* sigma = pixel_sigma_.ptr<float>(y);
  std::vector<int>& fit = scratch_.fit_columns;
  fit.clear();
  int ready_end = 0;  // ratios of this row are computed for the columns below it
  for (int x = first_changed; x < cols; ++x) {
    if (same[x]) {
      x = skipUnchanged(same, x, cols) - 1;
      continue;
    }
    const bool takes_fit = fits_row && x > 1 && x < cols - 2;
    if (takes_fit && x >= ready_end) {
      ensureRatios(y, x, x + 1);
      ready_end = (x / kRatioBlock + 1) * kRatioBlock;
    }
    if (takes_fit && centre[x] >= o.shadow_min_ratio && centre[x] <= o.shadow_max_ratio &&
        (!color || keepsBackgroundColor(in + 3 * x, mu + 3 * x, sigma[x])))
      fit.push_back(x);
    else
      candidate[x] = 255;
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
  ready_end = 0;  // now: of all five rows
  for (std::size_t i = 0; i < fit.size();) {
    const int x0 = fit[i];
    // fitPlanes reads two columns left of a group of four and two right of it.
    if (x0 + 6 > ready_end) {
      for (int dy = -2; dy <= 2; ++dy) ensureRatios(y + dy, x0 - 2, x0 + 6);
      ready_end = ((x0 + 5) / kRatioBlock + 1) * kRatioBlock;
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
        weak_min = cv::Point(std::min(weak_min.x, x), std::min(weak_min.y, y));
        weak_max = cv::Point(std::max(weak_max.x, x), std::max(weak_max.y, y));
      }
    }
  }
}

void SilhouetteExtractor::resolveWeakShadows(cv::Rect box) {
  // A smooth dark patch over a flat background fits a scaled background as well as a shadow does.
  // It is a shadow if it joins (8-connected, through weak or confident shadow pixels) a shadow that
  // showed the background's texture, else part of the person (a person's smooth clothing is ringed
  // by edges that fail the fit). Along any such path the last weak pixel before the first
  // confident one touches it: a flood through weak pixels, from those touching a confident one,
  // reaches exactly the weak pixels of such components. They all lie in the weak pixels' box, and
  // the confident pixels they touch at most one pixel outside it.
  const cv::Rect frame(cv::Point(0, 0), weak_shadow_.size());
  constexpr uint8_t kReached = 1;  // a weak pixel (255) found to be a shadow
  std::vector<int>& stack = scratch_.flood_stack;
  stack.clear();
  const auto touchesConfident = [&](int x, int y) {
    for (int ny = std::max(y - 1, 0); ny <= std::min(y + 1, frame.height - 1); ++ny) {
      const uint8_t* sure = shadow_.ptr<uint8_t>(ny);
      if (x > 0 && x + 1 < frame.width) {
        if (sure[x - 1] | sure[x] | sure[x + 1]) return true;
        continue;
      }
      for (int nx = std::max(x - 1, 0); nx <= std::min(x + 1, frame.width - 1); ++nx)
        if (sure[nx]) return true;
    }
    return false;
  };
  for (int y = box.y; y < box.br().y; ++y) {
    uint8_t* weak = weak_shadow_.ptr<uint8_t>(y);
    for (int x = skipZero(weak, box.x, box.br().x); x < box.br().x;
         x = skipZero(weak, x + 1, box.br().x)) {
      if (!touchesConfident(x, y)) continue;
      weak[x] = kReached;
      stack.push_back(y * frame.width + x);
    }
  }
  while (!stack.empty()) {
    const int y = stack.back() / frame.width, x = stack.back() % frame.width;
    stack.pop_back();
    for (int ny = std::max(y - 1, box.y); ny <= std::min(y + 1, box.br().y - 1); ++ny) {
      uint8_t* weak = weak_shadow_.ptr<uint8_t>(ny);
      for (int nx = std::max(x - 1, box.x); nx <= std::min(x + 1, box.br().x - 1); ++nx) {
        if (weak[nx] != 255) continue;
        weak[nx] = kReached;
        stack.push_back(ny * frame.width + nx);
      }
    }
  }
  for (int y = box.y; y < box.br().y; ++y) {
    uint8_t* weak = weak_shadow_.ptr<uint8_t>(y);
    uint8_t* sure = shadow_.ptr<uint8_t>(y);
    uint8_t* candidate = scratch_.candidates.ptr<uint8_t>(y);
    for (int x = skipZero(weak, box.x, box.br().x); x < box.br().x;
         x = skipZero(weak, x + 1, box.br().x)) {
      (weak[x] == kReached ? sure : candidate)[x] = 255;
      weak[x] = 0;  // ready for the next frame
    }
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
