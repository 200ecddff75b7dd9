// The silhouette sources of a camera: the scene's truth, extraction and the threshold.
#include "server/silhouette_source.h"

#include <opencv2/imgproc.hpp>

namespace mocap {

const cv::Mat* SceneTruth::silhouette(std::size_t camera, uint64_t frame_sequence) {
  if (rendered_sequence_ != frame_sequence) {
    rendered_sequence_ = frame_sequence;
    rendered_ = truth_(frame_sequence);
  }
  return camera < rendered_.size() ? &rendered_[camera] : nullptr;
}

bool TrueSilhouettes::update(const cv::Mat& /*image*/, uint64_t frame_sequence,
                             SilhouetteMask& silhouette) {
  if (const cv::Mat* truth = truth_->silhouette(camera_, frame_sequence))
    silhouette = SilhouetteMask(*truth);
  return true;
}

bool ExtractedSilhouettes::update(const cv::Mat& image, uint64_t /*frame_sequence*/,
                                  SilhouetteMask& silhouette) {
  if (!extractor_.extract(image)) return false;
  silhouette = extractor_.silhouette();
  return true;
}

bool ThresholdedSilhouettes::update(const cv::Mat& image, uint64_t /*frame_sequence*/,
                                    SilhouetteMask& silhouette) {
  cv::Mat gray = image;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  cv::Mat binary;
  cv::threshold(gray, binary, 127, 255, cv::THRESH_BINARY);
  silhouette = SilhouetteMask(binary);
  return true;
}

}  // namespace mocap
