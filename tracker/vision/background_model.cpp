// Background learning by running sums, and the measures of a learned background.
#include "tracker/vision/background_model.h"

#include <stdexcept>

#include <opencv2/core.hpp>

namespace mocap {

bool BackgroundLearner::add(const cv::Mat& frame) {
  if (frame.empty() || frame.depth() != CV_8U || (frame.channels() != 1 && frame.channels() != 3))
    return false;
  if (frames_ > 0 && (frame.size() != sum_.size() || frame.channels() != sum_.channels()))
    return false;
  if (frames_ == 0) {
    sum_.create(frame.size(), CV_64FC(frame.channels()));
    sum_squares_.create(frame.size(), CV_64FC(frame.channels()));
    sum_.setTo(0);
    sum_squares_.setTo(0);
  }
  cv::Mat as_double;
  frame.convertTo(as_double, CV_64F);
  sum_ += as_double;
  sum_squares_ += as_double.mul(as_double);
  ++frames_;
  return true;
}

BackgroundModel BackgroundLearner::model() const {
  if (frames_ == 0) throw std::logic_error("background model: no frame was added");
  const double n = frames_;
  cv::Mat mean = sum_ / n;
  cv::Mat variance = sum_squares_ / n - mean.mul(mean);
  variance = cv::max(variance, 0.0);  // rounding can make a constant pixel's variance negative
  cv::Mat stddev;
  cv::sqrt(variance, stddev);
  BackgroundModel model;
  mean.convertTo(model.mean, CV_32F);
  stddev.convertTo(model.stddev, CV_32F);
  return model;
}

void BackgroundLearner::clear() {
  sum_.release();
  sum_squares_.release();
  frames_ = 0;
}

BackgroundModel learnBackground(const std::vector<cv::Mat>& frames) {
  BackgroundLearner learner;
  for (std::size_t i = 0; i < frames.size(); ++i)
    if (!learner.add(frames[i]))
      throw std::invalid_argument("background frame " + std::to_string(i) +
                                  ": not 8-bit gray/BGR of the first frame's size");
  return learner.model();
}

double unsteadyShare(const BackgroundModel& model, double grey_levels) {
  if (model.empty()) return 0;
  cv::Mat per_pixel = model.stddev.reshape(1, static_cast<int>(model.stddev.total()));
  cv::Mat largest;
  cv::reduce(per_pixel, largest, 1, cv::REDUCE_MAX);  // the largest channel of each pixel
  return static_cast<double>(cv::countNonZero(largest > grey_levels)) /
         static_cast<double>(model.stddev.total());
}

double changedShare(const BackgroundModel& before, const BackgroundModel& after, double sigmas,
                    double min_difference) {
  if (before.size() != after.size() || before.channels() != after.channels())
    throw std::invalid_argument(
        "changed share: the two background models differ in size or channels");
  if (before.empty()) return 0;
  const cv::Mat moved = cv::abs(after.mean - before.mean);
  const cv::Mat limit = cv::max(before.stddev * sigmas, min_difference);
  const cv::Mat excess = cv::Mat(moved - limit).reshape(1, static_cast<int>(before.mean.total()));
  cv::Mat largest;
  cv::reduce(excess, largest, 1, cv::REDUCE_MAX);  // the largest channel of each pixel
  return static_cast<double>(cv::countNonZero(largest > 0)) /
         static_cast<double>(before.mean.total());
}

}  // namespace mocap
