// Silhouette extraction: gain estimate, per-channel range test (vectorized by OpenCV), shadow test
// on the changed pixels only (gray: then joined to textured shadows by connectivity), morphology,
// contour-based blob and hole cleanup, slow adaptation.
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
  if (channels == 1) {
    // Gray shadow test: how far the background's texture stands out of the noise over each 5x5
    // patch once a plane is removed (a shadow scales that texture; a flat patch cannot show it).
    // Learned once: adaptation follows slow light changes, which barely change the texture.
    const cv::Mat mean = background_.mean(roi_);
    const cv::Mat ones = cv::Mat::ones(5, 1, CV_32F);
    const cv::Mat ramp = (cv::Mat_<float>(5, 1) << -2, -1, 0, 1, 2);
    cv::Mat sum, sum_sq, sum_x, sum_y, noise;
    cv::boxFilter(mean, sum, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
    cv::sqrBoxFilter(mean, sum_sq, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
    cv::sepFilter2D(mean, sum_x, CV_32F, ramp, ones);
    cv::sepFilter2D(mean, sum_y, CV_32F, ones, ramp);
    cv::sqrBoxFilter(pixel_sigma_, noise, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
    texture_ = sum_sq - sum.mul(sum) / 25.0f - (sum_x.mul(sum_x) + sum_y.mul(sum_y)) / 50.0f;
    cv::divide(cv::max(texture_, 0.0f), noise, texture_);
    weak_shadow_.create(stddev.size(), CV_8UC1);
    weak_shadow_.setTo(0);
    shadow_labels_.create(stddev.size(), CV_32SC1);
    shadow_union_.create(stddev.size(), CV_8UC1);
  }

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
  if (background_.channels() == 1) {
    // Gray shadow test: 1 / background, and the noise of the ratio frame/background summed over
    // each 5x5 patch (unnormalized box filter), (sigma / background)^2 per pixel.
    cv::add(mean, 1.0f, bound_scratch_);  // never divides by zero
    cv::divide(1.0f, bound_scratch_, inverse_mean_);
    cv::multiply(pixel_sigma_, inverse_mean_, bound_scratch_);
    cv::multiply(bound_scratch_, bound_scratch_, bound_scratch_);
    cv::boxFilter(bound_scratch_, ratio_noise_, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
  }
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
  const float noise_scale = o.shadow_texture_sigmas * o.shadow_texture_sigmas;
  const int last_row = mean.rows - 1, last_col = mean.cols - 1;
  cv::Point box_min(mean.cols, mean.rows), box_max(-1, -1);  // of the weak shadows
  for (int y = 0; y < mean.rows; ++y) {
    const uint8_t* same = unchanged_.ptr<uint8_t>(y);
    const float* noise_energy = ratio_noise_.ptr<float>(y);
    const float* texture = texture_.ptr<float>(y);
    uint8_t* weak = weak_shadow_.ptr<uint8_t>(y);
    uint8_t* candidate = candidates_.ptr<uint8_t>(y);
    uint8_t* shadow = shadow_.ptr<uint8_t>(y);
    for (int x = 0; x < mean.cols; ++x) {
      if (same[x]) {
        x = skipUnchanged(same, x, mean.cols) - 1;
        continue;
      }
      bool is_shadow = false;
      const float centre_ratio = normalized_.ptr<uint8_t>(y)[x] * inverse_mean_.ptr<float>(y)[x];
      if (o.suppress_shadows && y > 1 && y < last_row - 1 && x > 1 && x < last_col - 1 &&
          centre_ratio >= o.shadow_min_ratio && centre_ratio <= o.shadow_max_ratio) {
        // A shadow scales the background by a factor that varies smoothly (a soft edge is a ramp),
        // so over the 5x5 patch the ratio frame/background fits a plane up to the noise. A person
        // brings their own shading, stripes and edges and ignores the background's texture: the
        // plane leaves more than the learned noise (flat on flat stays ambiguous).
        float sum = 0, sum_sq = 0, sum_x = 0, sum_y = 0;
        for (int dy = -2; dy <= 2; ++dy) {
          const uint8_t* in = normalized_.ptr<uint8_t>(y + dy) + x;
          const float* inverse = inverse_mean_.ptr<float>(y + dy) + x;
          float row = 0;
          for (int dx = -2; dx <= 2; ++dx) {
            const float q = in[dx] * inverse[dx];
            row += q;
            sum_sq += q * q;
            sum_x += q * static_cast<float>(dx);
          }
          sum += row;
          sum_y += row * static_cast<float>(dy);
        }
        // Least-squares plane over the symmetric 5x5 grid: sum(dx^2) = sum(dy^2) = 50.
        const float ratio = sum / 25.0f;
        const float residual = sum_sq - sum * ratio - (sum_x * sum_x + sum_y * sum_y) / 50.0f;
        if (ratio >= o.shadow_min_ratio && ratio <= o.shadow_max_ratio &&
            residual <= noise_scale * noise_energy[x]) {
          if (ratio * ratio * texture[x] >= o.shadow_texture_contrast) {
            is_shadow = true;
          } else {
            weak[x] = 255;  // decided below by what it is connected to
            box_min = cv::Point(std::min(box_min.x, x), std::min(box_min.y, y));
            box_max = cv::Point(std::max(box_max.x, x), std::max(box_max.y, y));
            continue;
          }
        }
      }
      (is_shadow ? shadow : candidate)[x] = 255;
    }
  }
  if (box_max.x >= box_min.x) resolveWeakShadows(cv::Rect(box_min, box_max + cv::Point(1, 1)));
}

void SilhouetteExtractor::resolveWeakShadows(cv::Rect box) {
  // A smooth dark patch over a flat background fits a scaled background as well as a shadow does.
  // It is a shadow if it joins a shadow that showed the background's texture, else part of the
  // person (a person's smooth clothing is ringed by edges that fail the fit). A confident pixel
  // next to a weak one lies at most one pixel outside the weak pixels' box: the widened box holds
  // every connection that decides.
  box = cv::Rect(box.x - 1, box.y - 1, box.width + 2, box.height + 2) &
        cv::Rect(cv::Point(0, 0), weak_shadow_.size());
  cv::Mat weak = weak_shadow_(box), confident = shadow_(box), both = shadow_union_(box);
  cv::Mat labels = shadow_labels_(box);
  cv::bitwise_or(weak, confident, both);
  const int count = cv::connectedComponents(both, labels, 8, CV_32S);
  shadow_seeded_.assign(static_cast<std::size_t>(count), 0);
  for (int y = 0; y < box.height; ++y) {
    const uint8_t* sure = confident.ptr<uint8_t>(y);
    const int* label = labels.ptr<int>(y);
    for (int x = 0; x < box.width; ++x)
      if (sure[x]) shadow_seeded_[label[x]] = 1;
  }
  cv::Mat candidates = candidates_(box);
  for (int y = 0; y < box.height; ++y) {
    uint8_t* maybe = weak.ptr<uint8_t>(y);
    uint8_t* sure = confident.ptr<uint8_t>(y);
    uint8_t* candidate = candidates.ptr<uint8_t>(y);
    const int* label = labels.ptr<int>(y);
    for (int x = 0; x < box.width; ++x) {
      if (!maybe[x]) continue;
      (shadow_seeded_[label[x]] ? sure : candidate)[x] = 255;
      maybe[x] = 0;  // ready for the next frame
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
