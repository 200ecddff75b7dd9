// Background learning by running sums, and its FileStorage I/O.
#include "tracker/vision/background_model.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include <fcntl.h>
#include <unistd.h>

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

namespace {

// Writes the model to `path` with FileStorage; throws naming `path`.
void writeModel(const std::string& path, const BackgroundModel& model) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::WRITE | cv::FileStorage::BASE64);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": cannot write background model: " + e.err);
  }
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot open for writing");
  fs << "image_width" << model.mean.cols << "image_height" << model.mean.rows;
  fs << "channels" << model.channels();
  fs << "mean" << model.mean << "stddev" << model.stddev;
  fs.release();
}

// Flushes a file (or a directory's entries) to the disk; false on an error.
bool syncToDisk(const std::string& path, int flags) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0) return false;
  const bool synced = ::fsync(fd) == 0;
  return ::close(fd) == 0 && synced;
}

}  // namespace

void saveBackground(const std::string& path, const BackgroundModel& model) {
  if (model.empty()) throw std::runtime_error(path + ": background model is empty");
  // Written beside the target under a hidden name with the same extension (FileStorage picks the
  // format and compression from it), then renamed over it: a crash or a full disk never leaves a
  // half-written model where the daemon loads it.
  const std::filesystem::path target(path);
  const std::filesystem::path temporary =
      target.parent_path() /
      (".tmp-" + std::to_string(::getpid()) + "-" + target.filename().string());
  std::error_code ignored;
  try {
    writeModel(temporary.string(), model);
    // FileStorage does not report failed writes: reading the file back catches a truncated one.
    const BackgroundModel written = loadBackground(temporary.string());
    if (written.size() != model.size() || written.channels() != model.channels())
      throw std::runtime_error("reads back with another size");
    if (!syncToDisk(temporary.string(), O_RDONLY))
      throw std::runtime_error(std::string("cannot flush to disk: ") + std::strerror(errno));
  } catch (const std::exception& e) {
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error(path + ": background model not saved: " + e.what());
  }
  std::error_code error;
  std::filesystem::rename(temporary, target, error);
  if (error) {
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error(path + ": background model not saved: cannot rename " +
                             temporary.string() + ": " + error.message());
  }
  // The rename itself survives a power loss only once the directory is flushed.
  syncToDisk(target.parent_path().empty() ? "." : target.parent_path().string(),
             O_RDONLY | O_DIRECTORY);
}

namespace {

cv::Mat readImage(const cv::FileStorage& fs, const std::string& field, const std::string& path,
                  cv::Size size, int channels) {
  cv::FileNode node = fs[field];
  if (node.empty()) throw std::runtime_error(path + ": " + field + ": missing");
  cv::Mat m;
  try {
    node >> m;
  } catch (const cv::Exception&) {
    m.release();
  }
  if (m.empty()) throw std::runtime_error(path + ": " + field + ": not an OpenCV matrix");
  if (m.size() != size || m.channels() != channels || m.depth() != CV_32F)
    throw std::runtime_error(path + ": " + field + ": expected " + std::to_string(size.width) +
                             "x" + std::to_string(size.height) + " float with " +
                             std::to_string(channels) + " channel(s)");
  return m;
}

int readInt(const cv::FileStorage& fs, const std::string& field, const std::string& path) {
  cv::FileNode node = fs[field];
  if (node.empty() || !node.isInt() || static_cast<int>(node) <= 0)
    throw std::runtime_error(path + ": " + field + ": missing or not a positive integer");
  return static_cast<int>(node);
}

}  // namespace

BackgroundModel loadBackground(const std::string& path) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": not a readable OpenCV FileStorage file: " + e.err);
  }
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot open background model");
  const cv::Size size(readInt(fs, "image_width", path), readInt(fs, "image_height", path));
  const int channels = readInt(fs, "channels", path);
  if (channels != 1 && channels != 3)
    throw std::runtime_error(path + ": channels: expected 1 or 3, got " + std::to_string(channels));
  BackgroundModel model;
  model.mean = readImage(fs, "mean", path, size, channels);
  model.stddev = readImage(fs, "stddev", path, size, channels);
  return model;
}

}  // namespace mocap
