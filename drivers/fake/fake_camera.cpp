// The fake cameras' threads: pacing on CLOCK_MONOTONIC, fault injection, replay of stored frames.
#include "drivers/fake/fake_camera.h"

#include <chrono>

#include <opencv2/imgproc.hpp>

#include "drivers/clock.h"
#include "drivers/thread_name.h"

namespace mocap {

FakeCameraBase::~FakeCameraBase() { stop(); }

Status FakeCameraBase::start(FrameSink frames, DriverEventSink events) {
  if (thread_.joinable()) return Status::Error(info_.id + ": already started");
  frames_ = std::move(frames);
  events_ = std::move(events);
  stopping_ = false;
  thread_ = std::thread([this] {
    nameThisThread("mocapd-camera");
    run();
  });
  return Status::Ok();
}

void FakeCameraBase::stop() {
  {
    // Under the lock so a pacing wait cannot miss the wake-up.
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stopping_ = true;
  }
  stop_signal_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool FakeCameraBase::sleepUntil(int64_t time_ns) {
  // steady_clock is CLOCK_MONOTONIC on Linux, the clock frames are stamped with.
  const std::chrono::steady_clock::time_point deadline{std::chrono::nanoseconds(time_ns)};
  std::unique_lock<std::mutex> lock(stop_mutex_);
  return !stop_signal_.wait_until(lock, deadline, [this] { return stopping_.load(); });
}

void FakeCameraBase::deliver(Frame&& frame) {
  frame.camera = config_.index;
  ++delivered_;
  if (frames_) frames_(std::move(frame));
}

void FakeCameraBase::report(const std::string& message) {
  if (events_) events_(config_.index, message);
}

void FakeCameraBase::convertForOutput(cv::Mat& image) const {
  const std::string& format = info_.modes.front().pixel_format;
  if (format == kPixelGray && image.channels() == 3) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  if (format == kPixelBgr && image.channels() == 1) cv::cvtColor(image, image, cv::COLOR_GRAY2BGR);
}

FakeSceneCamera::FakeSceneCamera(std::shared_ptr<FakeScene> scene, int rig_camera, const CameraConfig& config,
                                 CameraInfo info, FakeFaults faults)
    : FakeCameraBase(std::move(info), config),
      scene_(std::move(scene)),
      rig_camera_(rig_camera),
      faults_(std::move(faults)) {}

FakeSceneCamera::~FakeSceneCamera() { stop(); }

void FakeSceneCamera::run() {
  FakeScene& scene = *scene_;
  const FakeSceneOptions& options = scene.options();
  const bool real_time = options.pacing == FakePacing::kRealTime;
  const int64_t interval = scene.intervalNs();
  FakeRenderScratch scratch(scene.model(), scene.rig()[rig_camera_].height);
  // Real time: join the scene's clock where it is now, like a camera switched on mid-session.
  const auto currentSequence = [&] {
    const int64_t since_epoch = monotonicNowNs() - scene.epochNs();
    return since_epoch <= 0 ? uint64_t{0} : static_cast<uint64_t>((since_epoch + interval - 1) / interval);
  };
  uint64_t sequence = real_time ? currentSequence() : 0;
  uint32_t lost = 0;
  bool disconnected = false;
  while (!stopping()) {
    if (options.frame_limit > 0 && sequence >= options.frame_limit) break;
    if (real_time) {
      if (!sleepUntil(scene.exposureTimeNs(sequence))) break;
      // More than a period late (a busy machine): skip to the newest frame, as a sensor with no
      // free buffer would, rather than deliver a growing backlog.
      const uint64_t now_sequence = currentSequence();
      if (now_sequence > sequence + 1) {
        const uint64_t skipped = now_sequence - 1 - sequence;
        lost += static_cast<uint32_t>(skipped);
        lost_ += skipped;
        sequence = now_sequence - 1;
      }
    }
    const bool gone = scene.inOutage(faults_.disconnect, rig_camera_, sequence);
    if (gone != disconnected) {
      disconnected = gone;
      report(gone ? info_.id + ": camera disconnected (simulated)" : info_.id + ": camera reconnected (simulated)");
    }
    if (gone || scene.inOutage(faults_.stall, rig_camera_, sequence) ||
        scene.dropped(faults_, rig_camera_, sequence)) {
      ++lost;
      ++lost_;
      ++sequence;
      continue;
    }
    Frame frame;
    frame.sequence = sequence;
    frame.timestamp_ns = scene.exposureTimeNs(sequence) + scene.jitterNs(rig_camera_, sequence);
    frame.dropped_before = lost;
    scene.render(rig_camera_, sequence, scratch, frame.image);
    convertForOutput(frame.image);
    lost = 0;
    deliver(std::move(frame));
    ++sequence;
  }
}

ReplaySource::ReplaySource(std::shared_ptr<const SessionReader> reader) : reader_(std::move(reader)) {
  const std::vector<SessionSet>& sets = reader_->sets();
  const std::size_t cameras = reader_->cameras().size();
  loop_sequences_.assign(cameras, 0);
  if (sets.empty()) return;
  origin_ns_ = sets.front().timestamp_ns;
  double fastest = 0;
  for (const SessionCamera& camera : reader_->cameras()) fastest = std::max(fastest, camera.fps);
  loop_span_ns_ = sets.back().timestamp_ns - origin_ns_ + static_cast<int64_t>(1e9 / fastest);
  for (const SessionSet& set : sets) {
    for (std::size_t c = 0; c < cameras; ++c) {
      if (set.frames[c]) loop_sequences_[c] = std::max(loop_sequences_[c], set.frames[c]->camera_sequence + 1);
    }
  }
}

int64_t ReplaySource::startNs() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!start_ns_) start_ns_ = monotonicNowNs();
  return *start_ns_;
}

FakeReplayCamera::FakeReplayCamera(std::shared_ptr<ReplaySource> source, int session_camera,
                                   const CameraConfig& config, CameraInfo info, FakeReplayOptions options)
    : FakeCameraBase(std::move(info), config),
      source_(std::move(source)),
      session_camera_(session_camera),
      options_(options) {}

FakeReplayCamera::~FakeReplayCamera() { stop(); }

void FakeReplayCamera::run() {
  const SessionReader& reader = source_->reader();
  const std::vector<SessionSet>& sets = reader.sets();
  uint32_t lost = 0;
  for (uint64_t loop = 0; !stopping(); ++loop) {
    const int64_t time_shift = static_cast<int64_t>(loop) * source_->loopSpanNs();
    const uint64_t sequence_shift = loop * source_->loopSequences(session_camera_);
    for (std::size_t i = 0; i < sets.size() && !stopping(); ++i) {
      const std::optional<IndexRecord>& record = sets[i].frames[session_camera_];
      if (!record) continue;
      const int64_t timestamp = record->timestamp_ns + time_shift;
      if (options_.real_time && !sleepUntil(source_->startNs() + (timestamp - source_->originNs()))) return;
      Expected<Frame> frame = reader.readFrame(i, session_camera_);
      if (!frame.ok()) {
        report(frame.error());
        ++lost;
        ++lost_;
        continue;
      }
      frame.value().timestamp_ns = timestamp;
      frame.value().sequence += sequence_shift;
      frame.value().dropped_before += lost;
      lost = 0;
      convertForOutput(frame.value().image);
      deliver(std::move(frame.value()));
    }
    if (!options_.loop) {
      report(info_.id + ": end of the recorded session");
      return;
    }
  }
}

}  // namespace mocap
