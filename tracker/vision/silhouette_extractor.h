// Per-camera silhouette extraction against a learned background (paper §8.1: background
// subtraction then a threshold), with global-gain compensation, shadow suppression, cleanup and an
// optional slow adaptation of the background. One extractor per camera; not thread-safe, called
// by that camera's pipeline thread only, on which it does all its work: it never uses OpenCV's
// thread pool, so cv::setNumThreads is the daemon's choice alone. No allocation per frame after the
// first ones (except inside OpenCV's contour finder and the SilhouetteMask constructor).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/vision/background_model.h"
#include "tracker/vision/silhouette_kernels.h"

namespace mocap {

struct SilhouetteOptions {
  // A pixel changed when a channel leaves mean +- max(threshold_sigmas * stddev, min_difference).
  float threshold_sigmas = 4.0f;
  float min_difference = 9.0f;  // gray levels; floors the noise a short capture underestimates

  // Shadows darken the background by a factor in [shadow_min_ratio, shadow_max_ratio]; BGR: the
  // colour stays that of the background within chroma_sigmas * stddev + chroma_ratio * brightness;
  // both: over the 5x5 neighbourhood the ratio frame / background (BGR: along the background's
  // colour) fits a plane (a soft shadow edge is a ramp) within texture_sigmas times the learned
  // noise. Such a patch is a shadow outright if the background's texture, scaled by the ratio,
  // carries texture_contrast times the noise energy; a flatter one only if it is connected to such
  // a shadow, else it is the person's.
  bool suppress_shadows = true;
  float shadow_min_ratio = 0.35f;
  float shadow_max_ratio = 0.97f;
  float shadow_chroma_sigmas = 3.0f;
  float shadow_chroma_ratio = 0.06f;
  float shadow_texture_sigmas = 2.5f;
  float shadow_texture_contrast = 8.0f;  // set on seeds 101-105 with texture_sigmas 2.5

  // Cleanup: opening removes speckle, closing bridges thin gaps (radii 0-63); then connected
  // regions smaller than min_blob_fraction of the image are dropped and holes smaller than
  // max_hole_fraction filled.
  int open_radius = 1;
  int close_radius = 2;
  double min_blob_fraction = 0.0005;
  double max_hole_fraction = 0.01;

  // Global gain: the frame's brightness relative to the background, estimated every frame on a
  // sparse grid of pixels that were background in the previous frame.
  bool compensate_gain = true;
  int gain_sample_step = 8;

  // Adaptation: every adapt_interval frames, background pixels (unchanged ones only: never a
  // person, a shadow, or anything that differs) are blended into the mean with adapt_rate.
  bool adaptive = true;
  int adapt_interval = 8;
  float adapt_rate = 0.1f;

  // Pixels outside the region of interest are never foreground; empty: the whole frame.
  cv::Rect region_of_interest;

  // Also build the bit-packed SilhouetteMask the likelihood consumes.
  bool build_silhouette_mask = true;
};

class SilhouetteExtractor {
 public:
  // Throws std::invalid_argument if the model is empty/inconsistent or the options out of range.
  explicit SilhouetteExtractor(BackgroundModel background, SilhouetteOptions options = {});

  // Classifies one frame: CV_8UC1 or CV_8UC3 matching the background. Returns false with
  // lastError() set on a mismatch (the frame path never throws).
  bool extract(const cv::Mat& frame);

  // Of the last successful extract(): 0/255 foreground at the frame's size, and the same as a mask.
  const cv::Mat& foreground() const { return foreground_; }
  const SilhouetteMask& silhouette() const { return silhouette_; }
  // 255 where a changed pixel was explained as shadow (before cleanup), for display and tests.
  const cv::Mat& shadows() const { return shadow_; }
  double gain() const { return gain_; }
  const BackgroundModel& background() const { return background_; }
  const SilhouetteOptions& options() const { return options_; }
  const std::string& lastError() const { return error_; }

  // Replaces the background (e.g. after a new capture) and restarts the gain and adaptation.
  void setBackground(BackgroundModel background);

 private:
  // Per-frame working buffers, sized by setBackground and reused by every frame.
  struct Scratch {
    cv::Mat region;                         // this frame's region of interest
    float scale = 1;                        // 1 / gain
    cv::Mat normalized;                     // the region divided by the gain (for adaptation)
    cv::Mat unchanged;                      // 255 where every channel is in range
    cv::Mat candidates;                     // changed and not shadow, before cleanup
    std::vector<uint8_t> written_rows;      // per row: candidates or shadows may be nonzero
    silhouette_kernels::PackedMask packed;  // the candidates through the morphology
    cv::Mat cleaned;
    // Of 5 rows (row y in slot y % 5), around changed pixels: frame / background and its square,
    // and 255 where a pixel may be a shadow (ShadowBand).
    cv::Mat ratio_rows, ratio_squares, band_rows;
    // Per ring slot and block of columns: the number of the row computed there (first_row_number
    // + y, growing from frame to frame), so a new row or frame needs no reset.
    std::vector<int64_t> ratio_done;
    int ratio_blocks = 0;  // per row
    int64_t first_row_number = 0;
    std::vector<int> fit_columns;  // one row's pixels that take the plane fit
    // Offsets into the (continuous) region-sized masks: this frame's weak shadow pixels, and the
    // flood through them.
    std::vector<std::ptrdiff_t> weak_pixels, flood_stack;
    std::vector<std::vector<cv::Point>> contours;
    std::vector<cv::Vec4i> hierarchy;
    std::vector<float> gain_samples;
    std::vector<uint32_t> histogram;  // of the gain samples' bits, to find their median
    std::vector<double> patch_sums;   // patchSums5x5's buffers
  };

  void rebuildBounds();
  void estimateGain(const cv::Mat& frame);
  void classify(const cv::Mat& region, float scale);
  void ensureRatios(int first_row, int last_row, int begin, int end);
  void computeRatios(int y, int from, int to);
  void classifyRow(int y);
  void resolveWeakShadows();
  void cleanup();
  void adapt();

  BackgroundModel background_;
  SilhouetteOptions options_;
  silhouette_kernels::ShadowBand shadow_band_;  // of the options
  cv::Rect roi_;
  cv::Mat mean_view_;      // the background's mean in the region of interest (shares its data)
  cv::Mat margin_;         // per channel: max(threshold_sigmas * stddev, min_difference)
  cv::Mat pixel_sigma_;    // CV_32FC1: mean stddev over channels
  cv::Mat inverse_mean_;   // gray: 1 / (mean + 1)
  cv::Mat grouped_bgr_;    // BGR: per row, the mean and 1 / (|mean|^2 + 1) (groupColourRow)
  cv::Mat ratio_noise_;    // sum over each 5x5 patch of the ratio's noise variance
  cv::Mat texture_;        // the background's texture energy over each 5x5 patch / noise
  cv::Mat inner_columns_;  // one row: 255 at the columns whose 5x5 patch lies in the region
  cv::Mat weak_shadow_;    // fits a shadow over a flat patch (255); 0 between frames
  cv::Mat lower_, upper_;  // CV_8UC(c): the unchanged range of each channel
  cv::Mat gain_expected_;  // at the gain's sample points: the background's brightness
  cv::Mat bound_scratch_;
  cv::Mat foreground_, shadow_;
  cv::Rect drawn_;  // within the region of interest: where the last frame's foreground was drawn
  silhouette_kernels::RunMorphology open_, close_;
  Scratch scratch_;
  SilhouetteMask silhouette_;
  double gain_ = 1.0;
  long frame_count_ = 0;
  std::string error_;
};

}  // namespace mocap
