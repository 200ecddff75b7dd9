// The per-subscriber pose stream. Locking: the publisher calls offer()/finish() with its own lock
// held; gRPC calls the reactions on its threads. StartWrite and Finish are called after releasing
// the stream's lock; `writing_` guarantees a single write in flight, so message_ is only touched
// by whoever started that write until OnWriteDone.
#include "server/pose_stream.h"

#include <deque>
#include <mutex>

#include "server/log.h"
#include "server/proto_conversion.h"

namespace mocap {
namespace {

class PoseStream final : public grpc::ServerWriteReactor<v1::Pose>, public PoseSubscriber {
 public:
  PoseStream(PosePublisher& publisher, const BodyModel& model, std::vector<int> joints)
      : publisher_(publisher), model_(model), joints_(std::move(joints)) {
    if (!publisher_.subscribe(this)) {
      finished_ = true;
      Finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, "the daemon is shutting down"));
    }
  }

  void offer(const SharedPose& pose) override {
    std::unique_lock lock(mutex_);
    if (finished_ || closing_) return;
    if (queue_.size() >= kSubscriberQueuePoses) {
      queue_.pop_front();
      ++missed_;
    }
    queue_.push_back(pose);
    if (!writing_) writeNext(lock);
  }

  void finish() override {
    std::unique_lock lock(mutex_);
    closing_ = true;
    if (!writing_) end(lock, grpc::Status::OK);
  }

  void OnWriteDone(bool ok) override {
    std::unique_lock lock(mutex_);
    writing_ = false;
    if (!ok || cancelled_) {
      end(lock, grpc::Status(grpc::StatusCode::CANCELLED, "the subscriber went away"));
    } else if (!queue_.empty()) {
      writeNext(lock);
    } else if (closing_) {
      end(lock, grpc::Status::OK);
    }
  }

  void OnCancel() override {
    std::unique_lock lock(mutex_);
    cancelled_ = true;
    if (!writing_) end(lock, grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"));
  }

  void OnDone() override {
    publisher_.unsubscribe(this);
    logDebug() << "pose subscriber done";
    delete this;
  }

 private:
  // Starts writing the oldest queued pose; releases the lock.
  void writeNext(std::unique_lock<std::mutex>& lock) {
    const SharedPose pose = std::move(queue_.front());
    queue_.pop_front();
    writing_ = true;
    const uint64_t missed = missed_;
    missed_ = 0;
    lock.unlock();
    poseToProto(*pose, model_, joints_, missed, message_);
    StartWrite(&message_);
  }

  // Finishes the call once; releases the lock.
  void end(std::unique_lock<std::mutex>& lock, const grpc::Status& status) {
    if (finished_) return;
    finished_ = true;
    queue_.clear();
    lock.unlock();
    Finish(status);
  }

  PosePublisher& publisher_;
  const BodyModel& model_;
  const std::vector<int> joints_;
  std::mutex mutex_;
  std::deque<SharedPose> queue_;
  uint64_t missed_ = 0;
  bool writing_ = false;
  bool closing_ = false;
  bool cancelled_ = false;
  bool finished_ = false;
  v1::Pose message_;
};

class RefusedStream final : public grpc::ServerWriteReactor<v1::Pose> {
 public:
  explicit RefusedStream(const grpc::Status& status) { Finish(status); }
  void OnDone() override { delete this; }
};

}  // namespace

grpc::ServerWriteReactor<v1::Pose>* startPoseStream(PosePublisher& publisher,
                                                    const BodyModel& model,
                                                    std::vector<int> joints) {
  return new PoseStream(publisher, model, std::move(joints));
}

grpc::ServerWriteReactor<v1::Pose>* refusedPoseStream(const grpc::Status& status) {
  return new RefusedStream(status);
}

}  // namespace mocap
