// The web view's camera images: the newest frame set's images and silhouettes, kept on the mask
// thread only while a browser asks for them, and encoded to JPEG on the web server's threads at
// most a few times a second per camera, whoever asks, halved in size until at most 640 pixels wide
// (a page shows the cameras side by side at about that size).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "drivers/sync/frame_synchronizer.h"
#include "tracker/likelihood/silhouette_mask.h"

namespace mocap {

class CameraImages {
 public:
  // `min_interval`: a camera's JPEG is encoded at most once per interval; requests in between get
  // the last one.
  CameraImages(std::size_t cameras, std::chrono::milliseconds min_interval);

  // Mask thread: keeps the set's images and silhouettes when a browser asked for an image
  // lately, at most twice per interval (a copy of each mask: about 120 KB at 780x580). Quick.
  void keep(const FrameSet& set, const std::vector<SilhouetteMask>& masks);

  // Web server threads: camera `camera`'s newest image with its silhouette tinted green, as
  // JPEG; empty before its first frame or for an unknown camera.
  std::optional<std::string> jpeg(std::size_t camera);

  // The colour the silhouette is tinted with (BGR), for the page and its tests.
  static constexpr unsigned char kTintBgr[3] = {0, 255, 0};

 private:
  struct Cached {
    std::mutex mutex;
    cv::Mat scaled;                    // reused: a new buffer per image costs page faults
    cv::Mat tinted;                    // likewise
    std::vector<unsigned char> bytes;  // likewise
    std::string jpeg;
    uint64_t set_sequence = 0;
    std::chrono::steady_clock::time_point encoded{};
  };
  const std::chrono::milliseconds min_interval_;
  std::atomic<int64_t> wanted_until_ns_{0};  // steady clock: keep() keeps frames until then
  std::mutex mutex_;                         // guards the four below
  std::vector<cv::Mat> images_;
  std::vector<std::shared_ptr<const SilhouetteMask>> masks_;
  uint64_t set_sequence_ = 0;
  std::chrono::steady_clock::time_point kept_{};
  std::vector<std::unique_ptr<Cached>> cache_;
};

}  // namespace mocap
