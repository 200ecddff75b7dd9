// The silhouette extractor as first written, pass by pass with OpenCV calls and plain loops: what
// the optimized SilhouetteExtractor must reproduce bit for bit. For tests only.
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tracker/vision/silhouette_extractor.h"

namespace mocap::testing {

// Masks, shadows, gain and the adapted model.
class ReferenceExtractor {
 public:
  ReferenceExtractor(BackgroundModel background, const SilhouetteOptions& options)
      : model_(std::move(background)), o_(options) {
    const cv::Rect frame(cv::Point(0, 0), model_.size());
    roi_ = o_.region_of_interest.empty() ? frame : (o_.region_of_interest & frame);
    const cv::Mat stddev = model_.stddev(roi_);
    margin_ = cv::max(stddev * o_.threshold_sigmas, o_.min_difference);
    cv::Mat flat = stddev.clone().reshape(1, stddev.rows * stddev.cols);
    cv::reduce(flat, sigma_, 1, cv::REDUCE_AVG);
    sigma_ = cv::max(sigma_.reshape(1, stddev.rows), 1.0f);
    learnTexture();
    foreground_ = cv::Mat::zeros(model_.size(), CV_8UC1);
    shadow_ = cv::Mat::zeros(roi_.size(), CV_8UC1);
    bounds();
  }

  void extract(const cv::Mat& frame) {
    const cv::Mat region = frame(roi_);
    if (o_.compensate_gain) estimateGain(region);
    region.convertTo(normalized_, region.type(), 1.0 / gain_);
    cv::inRange(normalized_, lower_, upper_, unchanged_);
    candidates_ = cv::Mat::zeros(roi_.size(), CV_8UC1);
    shadow_ = cv::Mat::zeros(roi_.size(), CV_8UC1);
    weak_ = cv::Mat::zeros(roi_.size(), CV_8UC1);
    for (int y = 0; y < roi_.height; ++y)
      for (int x = 0; x < roi_.width; ++x)
        if (!unchanged_.at<uint8_t>(y, x)) classify(y, x) = 255;
    resolveWeak();
    cleanup();
    if (o_.adaptive && ++frames_ % o_.adapt_interval == 0) {
      cv::Mat mask;
      cv::subtract(unchanged_, foreground_(roi_), mask);
      cv::Mat mean = model_.mean(roi_);
      cv::accumulateWeighted(normalized_, mean, o_.adapt_rate, mask);
      bounds();
    }
  }

  const cv::Mat& foreground() const { return foreground_; }
  const cv::Mat& shadows() const { return shadow_; }
  double gain() const { return gain_; }
  const BackgroundModel& background() const { return model_; }

 private:
  // Texture of the mean (gray) or of its per-pixel colour magnitude (BGR).
  void learnTexture() {
    cv::Mat mean = model_.mean(roi_);
    if (model_.channels() == 3) {
      cv::Mat magnitude(mean.size(), CV_32FC1);
      for (int y = 0; y < mean.rows; ++y)
        for (int x = 0; x < mean.cols; ++x) {
          const cv::Vec3f mu = mean.at<cv::Vec3f>(y, x);
          magnitude.at<float>(y, x) = std::sqrt(mu[0] * mu[0] + mu[1] * mu[1] + mu[2] * mu[2]);
        }
      mean = magnitude;
    }
    const cv::Mat ones = cv::Mat::ones(5, 1, CV_32F);
    const cv::Mat ramp = (cv::Mat_<float>(5, 1) << -2, -1, 0, 1, 2);
    cv::Mat sum, sum_sq, sum_x, sum_y, noise;
    cv::boxFilter(mean, sum, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
    cv::sqrBoxFilter(mean, sum_sq, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
    cv::sepFilter2D(mean, sum_x, CV_32F, ramp, ones);
    cv::sepFilter2D(mean, sum_y, CV_32F, ones, ramp);
    cv::sqrBoxFilter(sigma_, noise, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
    texture_ = sum_sq - sum.mul(sum) / 25.0f - (sum_x.mul(sum_x) + sum_y.mul(sum_y)) / 50.0f;
    cv::divide(cv::max(texture_, 0.0f), noise, texture_);
  }

  void bounds() {
    const cv::Mat mean = model_.mean(roi_);
    cv::Mat(mean - margin_).convertTo(lower_, CV_8U);
    cv::Mat(mean + margin_).convertTo(upper_, CV_8U);
    cv::Mat noise;
    if (model_.channels() == 1) {
      cv::Mat shifted = mean + 1.0f;
      cv::divide(1.0f, shifted, inverse_);
      cv::multiply(sigma_, inverse_, noise);
      cv::multiply(noise, noise, noise);
    } else {
      inverse_.create(mean.size(), CV_32FC1);
      for (int y = 0; y < mean.rows; ++y)
        for (int x = 0; x < mean.cols; ++x) {
          const cv::Vec3f mu = mean.at<cv::Vec3f>(y, x);
          inverse_.at<float>(y, x) = 1.0f / (mu[0] * mu[0] + mu[1] * mu[1] + mu[2] * mu[2] + 1.0f);
        }
      cv::multiply(sigma_, sigma_, noise);
      cv::multiply(noise, inverse_, noise);
    }
    cv::boxFilter(noise, ratio_noise_, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false);
  }

  void estimateGain(const cv::Mat& frame) {
    const cv::Mat mean = model_.mean(roi_);
    const int channels = mean.channels(), step = o_.gain_sample_step;
    std::vector<float> samples;
    for (int y = step / 2; y < mean.rows; y += step)
      for (int x = step / 2; x < mean.cols; x += step) {
        if (foreground_(roi_).at<uint8_t>(y, x) || shadow_.at<uint8_t>(y, x)) continue;
        float observed = 0, expected = 0;
        for (int c = 0; c < channels; ++c) {
          observed += frame.ptr<uint8_t>(y)[x * channels + c];
          expected += mean.ptr<float>(y)[x * channels + c];
        }
        if (expected < 20.0f * channels || observed > 250.0f * channels) continue;
        samples.push_back(observed / expected);
      }
    if (samples.size() < 32) return;
    std::nth_element(samples.begin(), samples.begin() + samples.size() / 2, samples.end());
    gain_ = samples[samples.size() / 2];
  }

  // Whether a changed colour pixel keeps the background's colour, scaled.
  bool keepsColor(int y, int x) const {
    const cv::Vec3b in = normalized_.at<cv::Vec3b>(y, x);
    const cv::Vec3f mu = model_.mean(roi_).at<cv::Vec3f>(y, x);
    const float b = in[0], g = in[1], r = in[2];
    const float energy = mu[0] * mu[0] + mu[1] * mu[1] + mu[2] * mu[2] + 1.0f;
    const float ratio = (b * mu[0] + g * mu[1] + r * mu[2]) / energy;
    const float db = b - ratio * mu[0], dg = g - ratio * mu[1], dr = r - ratio * mu[2];
    const float tolerance = o_.shadow_chroma_sigmas * sigma_.at<float>(y, x) +
                            o_.shadow_chroma_ratio * ratio * std::sqrt(energy);
    return db * db + dg * dg + dr * dr <= tolerance * tolerance;
  }

  // frame / background: gray, of the pixel; BGR, along the background's colour.
  float ratio(int y, int x) const {
    if (model_.channels() == 1) return normalized_.at<uint8_t>(y, x) * inverse_.at<float>(y, x);
    const cv::Vec3b in = normalized_.at<cv::Vec3b>(y, x);
    const cv::Vec3f mu = model_.mean(roi_).at<cv::Vec3f>(y, x);
    return (in[0] * mu[0] + in[1] * mu[1] + in[2] * mu[2]) * inverse_.at<float>(y, x);
  }

  // The mask (candidates, shadows or weak shadows) a changed pixel goes to.
  uint8_t& classify(int y, int x) {
    const bool inside = y > 1 && y < roi_.height - 2 && x > 1 && x < roi_.width - 2;
    if (!o_.suppress_shadows || !inside || ratio(y, x) < o_.shadow_min_ratio ||
        ratio(y, x) > o_.shadow_max_ratio || (model_.channels() == 3 && !keepsColor(y, x)))
      return candidates_.at<uint8_t>(y, x);
    float sum = 0, sum_sq = 0, sum_x = 0, sum_y = 0;
    for (int dy = -2; dy <= 2; ++dy) {
      float row = 0;
      for (int dx = -2; dx <= 2; ++dx) {
        const float q = ratio(y + dy, x + dx);
        row += q;
        sum_sq += q * q;
        sum_x += q * static_cast<float>(dx);
      }
      sum += row;
      sum_y += row * static_cast<float>(dy);
    }
    const float mean = sum / 25.0f;
    const float residual = sum_sq - sum * mean - (sum_x * sum_x + sum_y * sum_y) / 50.0f;
    const float scale = o_.shadow_texture_sigmas * o_.shadow_texture_sigmas;
    if (mean < o_.shadow_min_ratio || mean > o_.shadow_max_ratio ||
        !(residual <= scale * ratio_noise_.at<float>(y, x)))
      return candidates_.at<uint8_t>(y, x);
    if (mean * mean * texture_.at<float>(y, x) >= o_.shadow_texture_contrast)
      return shadow_.at<uint8_t>(y, x);
    return weak_.at<uint8_t>(y, x);
  }

  // Weak shadows joined (8-connected through weak or confident shadows) to a confident one.
  void resolveWeak() {
    cv::Mat labels;
    const int count = cv::connectedComponents(weak_ | shadow_, labels, 8, CV_32S);
    std::vector<bool> seeded(static_cast<std::size_t>(count), false);
    for (int y = 0; y < roi_.height; ++y)
      for (int x = 0; x < roi_.width; ++x)
        if (shadow_.at<uint8_t>(y, x)) seeded[labels.at<int>(y, x)] = true;
    for (int y = 0; y < roi_.height; ++y)
      for (int x = 0; x < roi_.width; ++x)
        if (weak_.at<uint8_t>(y, x))
          (seeded[labels.at<int>(y, x)] ? shadow_ : candidates_).at<uint8_t>(y, x) = 255;
  }

  cv::Mat disk(int radius) const {
    return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
  }

  void cleanup() {
    cv::Mat cleaned = candidates_.clone();
    if (o_.open_radius > 0)
      cv::morphologyEx(cleaned, cleaned, cv::MORPH_OPEN, disk(o_.open_radius));
    if (o_.close_radius > 0)
      cv::morphologyEx(cleaned, cleaned, cv::MORPH_CLOSE, disk(o_.close_radius));
    std::vector<std::vector<cv::Point>> contours;
    std::vector<cv::Vec4i> hierarchy;
    cv::findContours(cleaned, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE);
    foreground_.setTo(0);
    cv::Mat out = foreground_(roi_);
    const double area = static_cast<double>(roi_.area());
    for (int i = 0; i >= 0 && i < static_cast<int>(contours.size()); i = hierarchy[i][0]) {
      if (cv::contourArea(contours[i]) < o_.min_blob_fraction * area) continue;
      cv::drawContours(out, contours, i, 255, cv::FILLED);
      for (int hole = hierarchy[i][2]; hole >= 0; hole = hierarchy[hole][0]) {
        if (cv::contourArea(contours[hole]) <= o_.max_hole_fraction * area) continue;
        cv::drawContours(out, contours, hole, 0, cv::FILLED);
        cv::drawContours(out, contours, hole, 255, 1);
      }
    }
  }

  BackgroundModel model_;
  SilhouetteOptions o_;
  cv::Rect roi_;
  cv::Mat margin_, sigma_, texture_, inverse_, ratio_noise_, lower_, upper_;
  cv::Mat normalized_, unchanged_, candidates_, shadow_, weak_, foreground_;
  double gain_ = 1.0;
  long frames_ = 0;
};

}  // namespace mocap::testing
