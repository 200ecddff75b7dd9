// Shared by the driver tests: collects the frames and driver events a camera delivers on its own
// threads, for the test thread to wait on with a timeout and then inspect.
#pragma once

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <initializer_list>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "drivers/camera_driver.h"
#include "drivers/frame.h"

namespace mocap {

class FrameCollector {
 public:
  // Each wait gives up after timeout. With prefix_camera, an event is kept as "<camera> <message>",
  // otherwise as the message alone.
  explicit FrameCollector(std::chrono::milliseconds timeout, bool prefix_camera = false)
      : timeout_(timeout), prefix_camera_(prefix_camera) {}

  FrameSink frameSink() {
    return [this](Frame&& frame) {
      std::lock_guard<std::mutex> lock(mutex_);
      frames_.push_back(std::move(frame));
      changed_.notify_all();
    };
  }
  DriverEventSink eventSink() {
    return [this](int camera, const std::string& message) {
      std::lock_guard<std::mutex> lock(mutex_);
      events_.push_back(prefix_camera_ ? std::to_string(camera) + " " + message : message);
      changed_.notify_all();
    };
  }
  bool waitForFrames(std::size_t count) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout_, [&] { return frames_.size() >= count; });
  }
  bool waitForEvents(std::size_t count) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout_, [&] { return events_.size() >= count; });
  }
  // Waits for an event containing the text.
  bool waitForEvent(const std::string& text) { return waitForEvent({text}); }
  // Waits for an event containing every one of the given texts.
  bool waitForEvent(std::initializer_list<std::string> texts) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout_, [&] {
      return std::any_of(events_.begin(), events_.end(), [&](const std::string& event) {
        return std::all_of(texts.begin(), texts.end(), [&](const std::string& text) {
          return event.find(text) != std::string::npos;
        });
      });
    });
  }
  std::vector<Frame> frames() {
    std::lock_guard<std::mutex> lock(mutex_);
    return frames_;
  }
  std::size_t frameCount() {
    std::lock_guard<std::mutex> lock(mutex_);
    return frames_.size();
  }
  std::vector<std::string> events() {
    std::lock_guard<std::mutex> lock(mutex_);
    return events_;
  }

 private:
  const std::chrono::milliseconds timeout_;
  const bool prefix_camera_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Frame> frames_;
  std::vector<std::string> events_;
};

}  // namespace mocap
