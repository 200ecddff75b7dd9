// Where one camera's silhouettes come from: the fake scene's truth, extraction against a learned
// background, or a threshold on the image (until a background is captured). The background
// manager picks each camera's source; the mask thread calls update() with every frame of that
// camera. A source is used by one thread at a time (the mask thread, or the constructor before it
// starts).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/vision/background_model.h"
#include "tracker/vision/silhouette_extractor.h"

namespace mocap {

// The silhouettes of frame `frame_sequence` on every camera, when the source knows them (the fake
// scene's ground truth); empty otherwise.
using GroundTruthSilhouettes = std::function<std::vector<cv::Mat>(uint64_t frame_sequence)>;

class SilhouetteSource {
 public:
  virtual ~SilhouetteSource() = default;
  // Mask thread: replaces `silhouette` by the one of `image`, camera's frame `frame_sequence`.
  // False when the source cannot use the image (lastError() says why); `silhouette` is unchanged.
  virtual bool update(const cv::Mat& image, uint64_t frame_sequence,
                      SilhouetteMask& silhouette) = 0;
  virtual std::string lastError() const { return ""; }
};

// The truth of every camera, rendered once per frame number and shared by the cameras' sources
// (the frames of one set normally share the scene's frame number).
class SceneTruth {
 public:
  explicit SceneTruth(GroundTruthSilhouettes truth) : truth_(std::move(truth)) {}
  // Camera `camera`'s true silhouette of frame `frame_sequence`; null if the truth has none.
  const cv::Mat* silhouette(std::size_t camera, uint64_t frame_sequence);

 private:
  GroundTruthSilhouettes truth_;
  std::optional<uint64_t> rendered_sequence_;
  std::vector<cv::Mat> rendered_;
};

// The scene's true silhouettes: the demo measures tracking, not segmentation.
class TrueSilhouettes final : public SilhouetteSource {
 public:
  TrueSilhouettes(std::shared_ptr<SceneTruth> truth, std::size_t camera)
      : truth_(std::move(truth)), camera_(camera) {}
  // Keeps the previous silhouette when the truth has none for this camera.
  bool update(const cv::Mat& image, uint64_t frame_sequence, SilhouetteMask& silhouette) override;

 private:
  std::shared_ptr<SceneTruth> truth_;
  std::size_t camera_;
};

// Extracted against a learned background, with shadow suppression.
class ExtractedSilhouettes final : public SilhouetteSource {
 public:
  // Throws std::invalid_argument for a background the extractor cannot use.
  explicit ExtractedSilhouettes(const BackgroundModel& background) : extractor_(background) {}
  // False for an image of another format than the background's.
  bool update(const cv::Mat& image, uint64_t frame_sequence, SilhouetteMask& silhouette) override;
  std::string lastError() const override { return extractor_.lastError(); }

 private:
  SilhouetteExtractor extractor_;
};

// Foreground where the image is brighter than mid-grey: a lit subject against a dark background,
// until a background is captured.
class ThresholdedSilhouettes final : public SilhouetteSource {
 public:
  bool update(const cv::Mat& image, uint64_t frame_sequence, SilhouetteMask& silhouette) override;
};

}  // namespace mocap
