// The web view's camera images.
#include "server/web_images.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <thread>

namespace mocap {
namespace {

int64_t steadyNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// How long after a browser's last image request frames are still kept for it.
constexpr auto kWantedFor = std::chrono::seconds(2);
constexpr int kJpegQuality = 80;
// Wider images are halved until they fit: a quarter of the pixels costs about a quarter of the
// encoding, and the page draws the image at the camera's size whatever its own.
constexpr int kMaxJpegWidth = 640;
// The tint's weight in 256ths (0.6): every tinted pixel is then at least 51 greener than it is
// red or blue, whatever its colour (pure red becomes 102,153,0), so the silhouette stays
// distinguishable from the subject.
constexpr int kTintWeight = 154;

// `image` shrunk by `shrink` (1, 2, 4, ...) as BGR in `bgr` (buffers reused), with the tint
// blended in where `mask`, at the image's size, is set in the first row of a pixel's block. It is
// shrunk first, so only the sent pixels are copied and tinted; only the silhouette's are touched.
void shrinkAndTint(const cv::Mat& image, int shrink, const SilhouetteMask* mask, cv::Mat& shrunk,
                   cv::Mat& bgr) {
  const cv::Size size(image.cols / shrink, image.rows / shrink);
  if (image.channels() == 1) {
    if (shrink > 1) cv::resize(image, shrunk, size, 0, 0, cv::INTER_AREA);
    cv::cvtColor(shrink > 1 ? shrunk : image, bgr, cv::COLOR_GRAY2BGR);
  } else if (shrink > 1) {
    cv::resize(image, bgr, size, 0, 0, cv::INTER_AREA);
  } else {
    image.copyTo(bgr);
  }
  if (!mask || mask->width() != image.cols || mask->height() != image.rows) return;
  const int block = std::max(1, 64 / shrink);  // 64 of the mask's pixels
  for (int y = 0; y < bgr.rows; ++y) {
    const SilhouetteMask::Row row = mask->row(y * shrink);
    unsigned char* pixels = bgr.ptr<unsigned char>(y);
    for (int x0 = 0; x0 < bgr.cols; x0 += block) {
      const int x1 = std::min(x0 + block, bgr.cols);
      if (row.count(x0 * shrink, x1 * shrink) == 0) continue;
      for (int x = x0; x < x1; ++x) {
        if (row.count(x * shrink, (x + 1) * shrink) == 0) continue;
        for (int c = 0; c < 3; ++c) {
          unsigned char& value = pixels[3 * x + c];
          value = static_cast<unsigned char>(
              (value * (256 - kTintWeight) + CameraImages::kTintBgr[c] * kTintWeight + 128) >> 8);
        }
      }
    }
  }
}

}  // namespace

CameraImages::CameraImages(std::size_t cameras, std::chrono::milliseconds min_interval)
    : min_interval_(min_interval), images_(cameras), masks_(cameras) {
  for (std::size_t c = 0; c < cameras; ++c) cache_.push_back(std::make_unique<Cached>());
}

void CameraImages::keep(const FrameSet& set, const std::vector<SilhouetteMask>& masks) {
  if (steadyNowNs() > wanted_until_ns_.load(std::memory_order_relaxed)) return;
  const auto now = std::chrono::steady_clock::now();
  // The mask thread never waits for the view: a view thread holding the lock (preempted at idle
  // priority) costs this set's images, not the pipeline's time.
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock || now - kept_ < min_interval_ / 2) return;
  kept_ = now;
  set_sequence_ = set.sequence;
  for (std::size_t c = 0; c < images_.size(); ++c) {
    if (c < set.frames.size() && set.frames[c]) images_[c] = set.frames[c]->image;
    if (c < masks.size() && masks[c].width() > 0)
      masks_[c] = std::make_shared<const SilhouetteMask>(masks[c]);
  }
}

std::optional<std::string> CameraImages::jpeg(std::size_t camera) {
  if (camera >= cache_.size()) return std::nullopt;
  wanted_until_ns_.store(
      steadyNowNs() + std::chrono::duration_cast<std::chrono::nanoseconds>(kWantedFor).count(),
      std::memory_order_relaxed);
  Cached& cached = *cache_[camera];
  // One encoder per camera at a time; the others wait for it and get its result.
  std::lock_guard encoding(cached.mutex);
  const auto now = std::chrono::steady_clock::now();
  if (!cached.jpeg.empty() && now - cached.encoded < min_interval_) return cached.jpeg;
  cv::Mat image;
  std::shared_ptr<const SilhouetteMask> mask;
  uint64_t sequence = 0;
  // The first request starts the keeping of frames: wait for the next set rather than refuse.
  for (int wait = 0; wait < 10; ++wait) {
    {
      std::lock_guard lock(mutex_);
      image = images_[camera];
      mask = masks_[camera];
      sequence = set_sequence_;
    }
    if (!image.empty()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (image.empty()) {
    if (cached.jpeg.empty()) return std::nullopt;
    return cached.jpeg;
  }
  if (sequence != cached.set_sequence || cached.jpeg.empty()) {
    int shrink = 1;
    while (image.cols / shrink > kMaxJpegWidth) shrink *= 2;
    shrinkAndTint(image, shrink, mask.get(), cached.scaled, cached.tinted);
    cv::imencode(".jpg", cached.tinted, cached.bytes, {cv::IMWRITE_JPEG_QUALITY, kJpegQuality});
    cached.jpeg.assign(cached.bytes.begin(), cached.bytes.end());
    cached.set_sequence = sequence;
  }
  cached.encoded = now;
  return cached.jpeg;
}

}  // namespace mocap
