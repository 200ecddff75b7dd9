// Silhouette extraction: gain estimate, per-channel range test (vectorized by OpenCV), shadow test
// on the changed pixels only, morphology, contour-based blob and hole cleanup, slow adaptation.
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
  require(o.shadow_min_ratio > 0 && o.shadow_min_ratio < o.shadow_max_ratio &&
              o.shadow_max_ratio <= 1,
          "shadow ratio band must satisfy 0 < min < max <= 1");
  require(o.open_radius >= 0 && o.close_radius >= 0, "morphology radii must be >= 0");
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

cv::Mat diskKernel(int radius) {
  return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
}

}  // namespace

SilhouetteExtractor::SilhouetteExtractor(BackgroundModel background, SilhouetteOptions options)
    : options_(options) {
  checkOptions(options_);
  if (options_.open_radius > 0) open_kernel_ = diskKernel(options_.open_radius);
  if (options_.close_radius > 0) close_kernel_ = diskKernel(options_.close_radius);
  setBackground(std::move(background));
}

void SilhouetteExtractor::setBackground(BackgroundModel background) {
  if (background.empty() || background.mean.depth() != CV_32F ||
      (background.channels() != 1 && background.channels() != 3) ||
      background.stddev.size() != background.size() ||
      background.stddev.type() != background.mean.type())
    throw std::invalid_argument("background model: expected float mean and stddev of 1 or 3 "
                                "channels and equal sizes");
  background_ = std::move(background);
  const cv::Rect frame(cv::Point(0, 0), background_.size());
  roi_ = options_.region_of_interest.empty() ? frame : (options_.region_of_interest & frame);
  if (roi_.empty()) throw std::invalid_argument("region of interest lies outside the frame");

  const int channels = background_.channels();
  const cv::Mat stddev = background_.stddev(roi_);
  margin_ = cv::max(stddev * options_.threshold_sigmas, options_.min_difference);
  cv::Mat flat = stddev.clone().reshape(1, stddev.rows * stddev.cols);  // a region is not continuous
  cv::reduce(flat, pixel_sigma_, 1, cv::REDUCE_AVG);
  pixel_sigma_ = cv::max(pixel_sigma_.reshape(1, stddev.rows), 1.0f);  // floor: quantization

  const cv::Size size = roi_.size();
  lower_.create(size, CV_8UC(channels));
  upper_.create(size, CV_8UC(channels));
  unchanged_.create(size, CV_8UC1);
  candidates_.create(size, CV_8UC1);
  shadow_.create(size, CV_8UC1);
  cleaned_.create(size, CV_8UC1);
  foreground_.create(background_.size(), CV_8UC1);
  foreground_.setTo(0);
  shadow_.setTo(0);
  gain_samples_.reserve(static_cast<std::size_t>(size.area() / options_.gain_sample_step + 1));
  gain_ = 1.0;
  frame_count_ = 0;
  rebuildBounds();
}

void SilhouetteExtractor::rebuildBounds() {
  // Saturating conversions round and clip the float range to 8 bits, vectorized by OpenCV.
  const cv::Mat mean = background_.mean(roi_);
  cv::subtract(mean, margin_, bound_scratch_);
  bound_scratch_.convertTo(lower_, CV_8U);
  cv::add(mean, margin_, bound_scratch_);
  bound_scratch_.convertTo(upper_, CV_8U);
}

void SilhouetteExtractor::estimateGain(const cv::Mat& frame) {
  // Median of frame/background brightness over pixels that were background last frame: robust to
  // the person and shadows, and cheap on a sparse grid.
  const cv::Mat mean = background_.mean(roi_);
  const int channels = mean.channels();
  const int step = options_.gain_sample_step;
  const cv::Mat previous = foreground_(roi_);
  gain_samples_.clear();
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
      gain_samples_.push_back(observed / expected);
    }
  }
  if (gain_samples_.size() < 32) return;  // too little background seen: keep the last gain
  auto middle = gain_samples_.begin() + static_cast<std::ptrdiff_t>(gain_samples_.size() / 2);
  std::nth_element(gain_samples_.begin(), middle, gain_samples_.end());
  gain_ = *middle;
}

void SilhouetteExtractor::classifyColor() {
  const cv::Mat mean = background_.mean(roi_);
  const SilhouetteOptions& o = options_;
  for (int y = 0; y < mean.rows; ++y) {
    const uint8_t* same = unchanged_.ptr<uint8_t>(y);
    const uint8_t* in = normalized_.ptr<uint8_t>(y);
    const float* mu = mean.ptr<float>(y);
    const float* sigma = pixel_sigma_.ptr<float>(y);
    uint8_t* candidate = candidates_.ptr<uint8_t>(y);
    uint8_t* shadow = shadow_.ptr<uint8_t>(y);
    for (int x = 0; x < mean.cols; ++x) {
      if (same[x]) {
        x = skipUnchanged(same, x, mean.cols) - 1;
        continue;
      }
      const float b = in[3 * x], g = in[3 * x + 1], r = in[3 * x + 2];
      const float mb = mu[3 * x], mg = mu[3 * x + 1], mr = mu[3 * x + 2];
      const float energy = mb * mb + mg * mg + mr * mr + 1.0f;
      const float ratio = (b * mb + g * mg + r * mr) / energy;  // brightness relative to background
      bool is_shadow = false;
      if (o.suppress_shadows && ratio >= o.shadow_min_ratio && ratio <= o.shadow_max_ratio) {
        const float db = b - ratio * mb, dg = g - ratio * mg, dr = r - ratio * mr;
        const float tolerance =
            o.shadow_chroma_sigmas * sigma[x] + o.shadow_chroma_ratio * ratio * std::sqrt(energy);
        is_shadow = db * db + dg * dg + dr * dr <= tolerance * tolerance;
      }
      (is_shadow ? shadow : candidate)[x] = 255;
    }
  }
}

void SilhouetteExtractor::classifyGray() {
  const cv::Mat mean = background_.mean(roi_);
  const SilhouetteOptions& o = options_;
  const int last_row = mean.rows - 1, last_col = mean.cols - 1;
  for (int y = 0; y < mean.rows; ++y) {
    const uint8_t* same = unchanged_.ptr<uint8_t>(y);
    const float* sigma = pixel_sigma_.ptr<float>(y);
    uint8_t* candidate = candidates_.ptr<uint8_t>(y);
    uint8_t* shadow = shadow_.ptr<uint8_t>(y);
    for (int x = 0; x < mean.cols; ++x) {
      if (same[x]) {
        x = skipUnchanged(same, x, mean.cols) - 1;
        continue;
      }
      bool is_shadow = false;
      const float centre_ratio = normalized_.ptr<uint8_t>(y)[x] / (mean.ptr<float>(y)[x] + 1.0f);
      if (o.suppress_shadows && y > 1 && y < last_row - 1 && x > 1 && x < last_col - 1 &&
          centre_ratio >= o.shadow_min_ratio && centre_ratio <= o.shadow_max_ratio) {
        // A shadow scales the background's texture. Over the 5x5 patch, fit I - mean(I) =
        // ratio * (mu - mean(mu)): accept only if the fit leaves noise and the scaled texture is
        // clearly above the noise (a flat patch cannot tell a shadow from a dark object).
        float sum_i = 0, sum_m = 0, sum_im = 0, sum_mm = 0, sum_ii = 0;
        for (int dy = -2; dy <= 2; ++dy) {
          const uint8_t* in = normalized_.ptr<uint8_t>(y + dy) + x;
          const float* mu = mean.ptr<float>(y + dy) + x;
          for (int dx = -2; dx <= 2; ++dx) {
            const float i = in[dx], m = mu[dx];
            sum_i += i;
            sum_m += m;
            sum_im += i * m;
            sum_mm += m * m;
            sum_ii += i * i;
          }
        }
        constexpr float n = 25;
        const float cov = sum_im - sum_i * sum_m / n;
        const float var_m = sum_mm - sum_m * sum_m / n + 1e-3f;
        const float var_i = sum_ii - sum_i * sum_i / n;
        const float slope = cov / var_m;
        const float explained = slope * cov;
        const float residual = var_i - explained;
        const float noise = o.shadow_texture_sigmas * sigma[x];
        is_shadow = slope >= o.shadow_min_ratio && slope <= o.shadow_max_ratio &&
                    residual <= n * noise * noise && explained >= 2 * residual;
      }
      (is_shadow ? shadow : candidate)[x] = 255;
    }
  }
}

void SilhouetteExtractor::cleanup() {
  const cv::Mat* source = &candidates_;
  if (!open_kernel_.empty()) {
    cv::morphologyEx(*source, cleaned_, cv::MORPH_OPEN, open_kernel_);
    source = &cleaned_;
  }
  if (!close_kernel_.empty()) {
    cv::morphologyEx(*source, cleaned_, cv::MORPH_CLOSE, close_kernel_);
    source = &cleaned_;
  }
  cv::findContours(*source, contours_, hierarchy_, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE);

  foreground_.setTo(0);
  cv::Mat out = foreground_(roi_);
  const double image_area = static_cast<double>(roi_.area());
  const double min_blob = options_.min_blob_fraction * image_area;
  const double max_hole = options_.max_hole_fraction * image_area;
  // RETR_CCOMP: top-level contours are outer boundaries, their children the holes in them.
  for (int i = 0; i >= 0 && i < static_cast<int>(contours_.size()); i = hierarchy_[i][0]) {
    if (cv::contourArea(contours_[i]) < min_blob) continue;
    cv::drawContours(out, contours_, i, 255, cv::FILLED);
    for (int hole = hierarchy_[i][2]; hole >= 0; hole = hierarchy_[hole][0]) {
      if (cv::contourArea(contours_[hole]) <= max_hole) continue;
      cv::drawContours(out, contours_, hole, 0, cv::FILLED);
      cv::drawContours(out, contours_, hole, 255, 1);  // the hole's rim is foreground
    }
  }
}

void SilhouetteExtractor::adapt() {
  // Only pixels whose every channel matched the background and that are not inside a silhouette:
  // a person standing still, their shadow, or a slow-moving object never leak into the model.
  cv::subtract(unchanged_, foreground_(roi_), cleaned_);  // cleaned_ is free scratch by now
  cv::Mat mean = background_.mean(roi_);
  cv::accumulateWeighted(normalized_, mean, options_.adapt_rate, cleaned_);
  rebuildBounds();
}

bool SilhouetteExtractor::extract(const cv::Mat& frame) {
  if (frame.size() != background_.size() || frame.type() != CV_8UC(background_.channels())) {
    error_ = "frame is " + std::to_string(frame.cols) + "x" + std::to_string(frame.rows) + " with " +
             std::to_string(frame.channels()) + " channel(s) of depth " +
             std::to_string(frame.depth()) + ", background is " +
             std::to_string(background_.size().width) + "x" +
             std::to_string(background_.size().height) + " 8-bit with " +
             std::to_string(background_.channels()) + " channel(s)";
    return false;
  }
  error_.clear();
  const cv::Mat region = frame(roi_);
  if (options_.compensate_gain) estimateGain(region);
  region.convertTo(normalized_, region.type(), 1.0 / gain_);
  cv::inRange(normalized_, lower_, upper_, unchanged_);
  // Classification only visits changed pixels: start from "nothing found".
  candidates_.setTo(0);
  shadow_.setTo(0);
  if (background_.channels() == 3)
    classifyColor();
  else
    classifyGray();
  cleanup();
  if (options_.adaptive && ++frame_count_ % options_.adapt_interval == 0) adapt();
  if (options_.build_silhouette_mask) silhouette_ = SilhouetteMask(foreground_);
  return true;
}

}  // namespace mocap
