// Fans each pose out to the subscribers. publish() only hands a shared pointer to each
// subscriber's own small queue, so a stalled subscriber loses its old poses and never delays the
// tracker or the others.
#pragma once

#include <atomic>
#include <cstddef>
#include <mutex>
#include <vector>

#include "server/pose.h"

namespace mocap {

// One subscriber (a StreamPoses call). Both calls come with the publisher's lock held: they must
// not block and must not call back into the publisher.
class PoseSubscriber {
 public:
  virtual ~PoseSubscriber() = default;
  virtual void offer(const SharedPose& pose) = 0;
  // The publisher closes: deliver what is queued, then end the stream.
  virtual void finish() = 0;
};

class PosePublisher {
 public:
  // False once the publisher is closed (the subscriber should end at once).
  bool subscribe(PoseSubscriber* subscriber);
  // After it returns, the publisher never touches `subscriber` again.
  void unsubscribe(PoseSubscriber* subscriber);
  // Called on the publisher thread.
  void publish(const SharedPose& pose);
  // Ends every subscription and refuses new ones.
  void close();
  // Lock-free: the web view's idle-priority threads read it (server/web_view.cpp).
  std::size_t subscriberCount() const { return subscriber_count_.load(std::memory_order_relaxed); }

 private:
  std::mutex mutex_;
  std::vector<PoseSubscriber*> subscribers_;
  std::atomic<std::size_t> subscriber_count_{0};
  bool closed_ = false;
};

}  // namespace mocap
