// The soak's pose subscribers, each on its own thread and its own connection: live ones read every
// pose, stalled ones open a stream and never read, reconnecting ones open a new connection and
// stream every second. All of them come back after the daemon restarts.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "mocap/v1/mocap.grpc.pb.h"

namespace mocap::soak {

// Channel arguments that retry a lost daemon every second at most (gRPC's default backs off to
// two minutes), so every client is back soon after a restart.
grpc::ChannelArguments quickReconnectArguments();

enum class SubscriberKind { kLive, kStalled, kReconnecting };

struct SubscriberCounts {
  uint64_t received = 0;         // poses read
  uint64_t missed = 0;           // poses the daemon says it skipped for this subscriber
  uint64_t streams = 0;          // StreamPoses calls that delivered at least one pose
  double streaming_seconds = 0;  // from the first to the last pose of each stream, summed
};

class PoseSubscribers {
 public:
  // `count` subscribers of each kind to the daemon at `address` (plain text, loopback).
  PoseSubscribers(std::string address, int live, int stalled, int reconnecting);
  ~PoseSubscribers();
  void start();
  // Ends every stream and joins the threads.
  void stop();
  // The daemon came back: the stalled subscribers, whose stream died with it, open new ones.
  void daemonRestarted();
  // Totals so far over the subscribers of one kind, and each live subscriber's own.
  SubscriberCounts total(SubscriberKind kind) const;
  std::vector<SubscriberCounts> each(SubscriberKind kind) const;

 private:
  struct Subscriber {
    SubscriberKind kind;
    mutable std::mutex mutex;  // guards counts and context
    SubscriberCounts counts;
    grpc::ClientContext* context = nullptr;  // the stream open now, to cancel at stop
    std::thread thread;
  };
  void run(Subscriber& subscriber);
  // A pose stream on `context`, which stop() can then cancel; null once stopping.
  std::unique_ptr<grpc::ClientReader<v1::Pose>> openStream(
      Subscriber& subscriber, const std::shared_ptr<grpc::Channel>& channel,
      grpc::ClientContext& context);
  // Reads one stream to its end (or its deadline), counting what it delivers.
  void readStream(Subscriber& subscriber, const std::shared_ptr<grpc::Channel>& channel,
                  grpc::ClientContext& context);
  void holdStalledStream(Subscriber& subscriber, const std::shared_ptr<grpc::Channel>& channel);
  std::shared_ptr<grpc::Channel> newChannel() const;
  bool stopping() const { return stopping_; }

  const std::string address_;
  std::vector<std::unique_ptr<Subscriber>> subscribers_;
  std::atomic<bool> stopping_{false};
  std::mutex generation_mutex_;
  std::condition_variable generation_changed_;
  uint64_t generation_ = 0;  // daemon restarts so far
};

}  // namespace mocap::soak
