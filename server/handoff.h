// The bounded hand-off between two pipeline stages (one producer thread, one consumer thread).
// Live: one slot, a newer item replaces the waiting one (latest wins: latency beats completeness).
// Replay: a small queue and the producer waits while it is full, so nothing is lost and the
// result does not depend on thread timing.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>

namespace mocap {

template <typename T>
class Handoff {
 public:
  enum class Mode { kLatestWins, kLossless };

  Handoff(Mode mode, std::size_t lossless_capacity = 2)
      : mode_(mode), capacity_(mode == Mode::kLatestWins ? 1 : lossless_capacity) {}

  // Returns false once closed (the item is dropped).
  bool push(T item) {
    std::unique_lock lock(mutex_);
    if (mode_ == Mode::kLossless)
      space_.wait(lock, [&] { return closed_ || items_.size() < capacity_; });
    if (closed_) return false;
    if (items_.size() >= capacity_) {
      items_.pop_front();
      ++superseded_;
    }
    items_.push_back(std::move(item));
    ready_.notify_one();
    return true;
  }

  // The next item, waiting up to `timeout`; empty on timeout or once closed and drained.
  std::optional<T> pop(std::chrono::nanoseconds timeout) {
    std::unique_lock lock(mutex_);
    if (!ready_.wait_for(lock, timeout, [&] { return closed_ || !items_.empty(); })) return {};
    if (items_.empty()) return {};
    T item = std::move(items_.front());
    items_.pop_front();
    space_.notify_one();
    return item;
  }

  // Wakes both sides; pop() still drains what is queued.
  void close() {
    std::lock_guard lock(mutex_);
    closed_ = true;
    ready_.notify_all();
    space_.notify_all();
  }

  bool closed() const {
    std::lock_guard lock(mutex_);
    return closed_;
  }

  // Whether an item waits for the consumer.
  bool waiting() const {
    std::lock_guard lock(mutex_);
    return !items_.empty();
  }

  // Items replaced by a newer one before the consumer took them (live mode only).
  uint64_t superseded() const {
    std::lock_guard lock(mutex_);
    return superseded_;
  }

 private:
  const Mode mode_;
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::condition_variable space_;
  std::deque<T> items_;
  uint64_t superseded_ = 0;
  bool closed_ = false;
};

}  // namespace mocap
