// The learned appearance of the empty scene, per pixel: mean and standard deviation of each channel
// over N frames, for 8-bit gray or BGR cameras. Learned once (CaptureBackground), saved beside the
// calibration so a restarted daemon can extract silhouettes without a new capture.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace mocap {

struct BackgroundModel {
  cv::Mat mean;    // CV_32FC1 or CV_32FC3, the frame's size
  cv::Mat stddev;  // same type and size as mean

  bool empty() const { return mean.empty(); }
  int channels() const { return mean.channels(); }
  cv::Size size() const { return mean.size(); }
};

// Accumulates empty-scene frames one at a time (so a capture never holds N frames in memory).
class BackgroundLearner {
 public:
  // `frame`: CV_8UC1 or CV_8UC3, same size and type as the first one added. Returns false (and
  // leaves the learner unchanged) on a mismatch.
  bool add(const cv::Mat& frame);
  int frames() const { return frames_; }
  // The model learned so far; throws std::logic_error if no frame was added.
  BackgroundModel model() const;
  void clear();

 private:
  cv::Mat sum_, sum_squares_;  // CV_64FC(c): float sums lose precision past a few hundred frames
  int frames_ = 0;
};

BackgroundModel learnBackground(const std::vector<cv::Mat>& frames);

// The share of the model's pixels (0 to 1) whose standard deviation, in any channel, exceeds
// `grey_levels`: pixels that changed during the capture, where someone or something moved. Sensor
// noise stays far below the default (5 sigma of a noisy camera's 3 grey levels).
double unsteadyShare(const BackgroundModel& model, double grey_levels = 15);

// The share of pixels (0 to 1) whose mean, in any channel, moved from `before` to `after` by more
// than max(sigmas * before's standard deviation, min_difference) grey levels (the silhouette
// extractor's test, with its SilhouetteOptions): what changed in the room between two captures.
// Someone standing still through a capture is steady in it, but not in the background it
// replaces. Throws std::invalid_argument if the models differ in size or channels.
double changedShare(const BackgroundModel& before, const BackgroundModel& after, double sigmas,
                    double min_difference);

// The file is OpenCV FileStorage YAML with the matrices in base64 (image_width, image_height,
// channels, mean, stddev), gzip-compressed if the name ends in ".gz"; written and read without
// OpenCV's parser (background_file.cpp), which can hang on a malformed file.
// saveBackground replaces `path` atomically (a hidden temporary file in the same directory, read
// back, flushed, then renamed) and throws std::runtime_error naming the file. loadBackground reads
// that layout only and throws std::runtime_error naming the file and the field at fault, for sizes
// beyond 16384 pixels a side or 2^25 pixels, and for values that are not finite or deviations
// below zero (which saveBackground refuses to write).
void saveBackground(const std::string& path, const BackgroundModel& model);
BackgroundModel loadBackground(const std::string& path);

}  // namespace mocap
