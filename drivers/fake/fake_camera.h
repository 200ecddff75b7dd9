// The fake driver's cameras: one camera of the synthetic scene, and one camera of a recorded
// session played back. Each owns one thread that paces, produces and delivers its frames.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "drivers/camera_driver.h"
#include "drivers/fake/fake_scene.h"
#include "drivers/record/session_reader.h"

namespace mocap {

struct FakeCameraStats {
  uint64_t delivered = 0;
  uint64_t lost = 0;  // frames not delivered: drops, stalls, disconnections, falling behind, bad images
};

// The pacing and stopping shared by both kinds of fake camera.
class FakeCameraBase : public Camera {
 public:
  ~FakeCameraBase() override;
  const CameraInfo& info() const override { return info_; }
  Status start(FrameSink frames, DriverEventSink events) override;
  // Wakes the thread out of any wait and joins it: returns within one frame's render time.
  void stop() override;
  FakeCameraStats stats() const { return {delivered_.load(), lost_.load()}; }

 protected:
  FakeCameraBase(CameraInfo info, const CameraConfig& config) : info_(std::move(info)), config_(config) {}
  virtual void run() = 0;
  // Waits until CLOCK_MONOTONIC reaches `time_ns`; false if stop() was called first.
  bool sleepUntil(int64_t time_ns);
  bool stopping() const { return stopping_.load(); }
  void deliver(Frame&& frame);
  void report(const std::string& message);
  // Converts to the configured pixel format when the source's differs.
  void convertForOutput(cv::Mat& image) const;

  const CameraInfo info_;
  const CameraConfig config_;
  std::atomic<uint64_t> delivered_{0};
  std::atomic<uint64_t> lost_{0};

 private:
  std::thread thread_;
  FrameSink frames_;
  DriverEventSink events_;
  std::mutex stop_mutex_;
  std::condition_variable stop_signal_;
  std::atomic<bool> stopping_{false};
};

// Camera `rig_camera` of a FakeScene. Frame::sequence is the scene's frame number (so
// FakeScene::groundTruth(sequence) is the truth of that frame on every camera) and
// Frame::timestamp_ns its simulated exposure time plus jitter. Frames lost to faults or to falling
// behind real time leave a sequence gap that the next frame's dropped_before counts.
class FakeSceneCamera final : public FakeCameraBase {
 public:
  // `faults`: this camera's (the scene's unless its device string gives some).
  FakeSceneCamera(std::shared_ptr<FakeScene> scene, int rig_camera, const CameraConfig& config, CameraInfo info,
                  FakeFaults faults);
  ~FakeSceneCamera() override;

 private:
  void run() override;
  std::shared_ptr<FakeScene> scene_;
  const int rig_camera_;
  const FakeFaults faults_;
};

// How a recorded session plays.
struct FakeReplayOptions {
  bool real_time = true;  // at the recorded pace; false: as fast as the consumer takes them
  bool loop = false;      // start over at the end (timestamps and sequences keep increasing)
  SessionReadOptions read;
};

// What the cameras of one session share: the reader and the instant replay started, so they stay
// in step.
class ReplaySource {
 public:
  explicit ReplaySource(std::shared_ptr<const SessionReader> reader);
  const SessionReader& reader() const { return *reader_; }
  // CLOCK_MONOTONIC time of the session's first set, fixed by the first call.
  int64_t startNs();
  int64_t originNs() const { return origin_ns_; }  // recorded time of the first set
  // Added per loop to timestamps so a looped replay still moves forward: the recording's span
  // plus one period.
  int64_t loopSpanNs() const { return loop_span_ns_; }
  // Added per loop to each camera's sequences.
  uint64_t loopSequences(int camera) const { return loop_sequences_[camera]; }

 private:
  std::shared_ptr<const SessionReader> reader_;
  int64_t origin_ns_ = 0;
  int64_t loop_span_ns_ = 0;
  std::vector<uint64_t> loop_sequences_;
  std::mutex mutex_;
  std::optional<int64_t> start_ns_;
};

// Camera `session_camera` of a recorded session. The first pass delivers the recorded sequence,
// timestamp, flags and pixels exactly (only Frame::camera becomes the configured index). A frame
// whose image no longer decodes is reported and counted in the next frame's dropped_before.
// When the session ends without loop, the camera reports it and delivers nothing more.
class FakeReplayCamera final : public FakeCameraBase {
 public:
  FakeReplayCamera(std::shared_ptr<ReplaySource> source, int session_camera, const CameraConfig& config,
                   CameraInfo info, FakeReplayOptions options);
  ~FakeReplayCamera() override;

 private:
  void run() override;
  std::shared_ptr<ReplaySource> source_;
  const int session_camera_;
  const FakeReplayOptions options_;
};

}  // namespace mocap
