// The pose fan-out.
#include "server/pose_publisher.h"

#include <algorithm>

namespace mocap {

bool PosePublisher::subscribe(PoseSubscriber* subscriber) {
  std::lock_guard lock(mutex_);
  if (closed_) return false;
  subscribers_.push_back(subscriber);
  subscriber_count_ = subscribers_.size();
  return true;
}

void PosePublisher::unsubscribe(PoseSubscriber* subscriber) {
  std::lock_guard lock(mutex_);
  subscribers_.erase(std::remove(subscribers_.begin(), subscribers_.end(), subscriber),
                     subscribers_.end());
  subscriber_count_ = subscribers_.size();
}

void PosePublisher::publish(const SharedPose& pose) {
  std::lock_guard lock(mutex_);
  for (PoseSubscriber* subscriber : subscribers_) subscriber->offer(pose);
}

void PosePublisher::close() {
  std::lock_guard lock(mutex_);
  if (closed_) return;
  closed_ = true;
  for (PoseSubscriber* subscriber : subscribers_) subscriber->finish();
}

}  // namespace mocap
