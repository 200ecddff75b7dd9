// The soak's pose subscribers: one thread and one connection each.
#include "pose_subscribers.h"

#include <chrono>

namespace mocap::soak {
namespace {

using Clock = std::chrono::steady_clock;

double secondsBetween(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

}  // namespace

grpc::ChannelArguments quickReconnectArguments() {
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
  return args;
}

PoseSubscribers::PoseSubscribers(std::string address, int live, int stalled, int reconnecting)
    : address_(std::move(address)) {
  const auto add = [this](SubscriberKind kind, int count) {
    for (int i = 0; i < count; ++i) {
      subscribers_.push_back(std::make_unique<Subscriber>());
      subscribers_.back()->kind = kind;
    }
  };
  add(SubscriberKind::kLive, live);
  add(SubscriberKind::kStalled, stalled);
  add(SubscriberKind::kReconnecting, reconnecting);
}

PoseSubscribers::~PoseSubscribers() { stop(); }

void PoseSubscribers::start() {
  for (auto& subscriber : subscribers_)
    subscriber->thread = std::thread([this, s = subscriber.get()] { run(*s); });
}

void PoseSubscribers::stop() {
  stopping_ = true;
  {
    std::lock_guard<std::mutex> lock(generation_mutex_);
    generation_changed_.notify_all();
  }
  for (auto& subscriber : subscribers_) {
    {
      std::lock_guard<std::mutex> lock(subscriber->mutex);
      if (subscriber->context) subscriber->context->TryCancel();
    }
    if (subscriber->thread.joinable()) subscriber->thread.join();
  }
}

void PoseSubscribers::daemonRestarted() {
  std::lock_guard<std::mutex> lock(generation_mutex_);
  ++generation_;
  generation_changed_.notify_all();
}

std::shared_ptr<grpc::Channel> PoseSubscribers::newChannel() const {
  // A pool of its own: otherwise channels to one address share a connection, and 50 subscribers
  // would be 50 streams on one socket rather than 50 clients.
  grpc::ChannelArguments args = quickReconnectArguments();
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  return grpc::CreateCustomChannel(address_, grpc::InsecureChannelCredentials(), args);
}

void PoseSubscribers::run(Subscriber& subscriber) {
  std::shared_ptr<grpc::Channel> channel = newChannel();
  while (!stopping()) {
    if (subscriber.kind == SubscriberKind::kStalled) {
      holdStalledStream(subscriber, channel);
      continue;
    }
    grpc::ClientContext context;
    if (subscriber.kind == SubscriberKind::kReconnecting) {
      channel = newChannel();
      context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(1));
    }
    const Clock::time_point opened = Clock::now();
    readStream(subscriber, channel, context);
    // A stream that ends early (the daemon is down) is retried after a pause, not in a spin.
    if (!stopping() && Clock::now() - opened < std::chrono::milliseconds(900))
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
}

std::unique_ptr<grpc::ClientReader<v1::Pose>> PoseSubscribers::openStream(
    Subscriber& subscriber, const std::shared_ptr<grpc::Channel>& channel,
    grpc::ClientContext& context) {
  {
    std::lock_guard<std::mutex> lock(subscriber.mutex);
    if (stopping()) return nullptr;
    subscriber.context = &context;
  }
  return v1::MocapService::NewStub(channel)->StreamPoses(&context, v1::StreamPosesRequest());
}

void PoseSubscribers::readStream(Subscriber& subscriber,
                                 const std::shared_ptr<grpc::Channel>& channel,
                                 grpc::ClientContext& context) {
  std::unique_ptr<grpc::ClientReader<v1::Pose>> reader = openStream(subscriber, channel, context);
  if (!reader) return;
  v1::Pose pose;
  Clock::time_point first;
  Clock::time_point last;
  bool any = false;
  while (reader->Read(&pose)) {
    last = Clock::now();
    if (!any) first = last;
    std::lock_guard<std::mutex> lock(subscriber.mutex);
    ++subscriber.counts.received;
    subscriber.counts.missed += pose.missed_before();
    if (!any) ++subscriber.counts.streams;
    any = true;
  }
  reader->Finish();
  std::lock_guard<std::mutex> lock(subscriber.mutex);
  if (any) subscriber.counts.streaming_seconds += secondsBetween(first, last);
  subscriber.context = nullptr;
}

void PoseSubscribers::holdStalledStream(Subscriber& subscriber,
                                        const std::shared_ptr<grpc::Channel>& channel) {
  uint64_t generation = 0;
  {
    std::lock_guard<std::mutex> lock(generation_mutex_);
    generation = generation_;
  }
  grpc::ClientContext context;
  // Opened, never read: the daemon's writes to it back up.
  std::unique_ptr<grpc::ClientReader<v1::Pose>> reader = openStream(subscriber, channel, context);
  if (!reader) return;
  {
    std::unique_lock<std::mutex> lock(generation_mutex_);
    generation_changed_.wait(lock, [&] { return stopping() || generation_ != generation; });
  }
  {
    std::lock_guard<std::mutex> lock(subscriber.mutex);
    context.TryCancel();
    subscriber.context = nullptr;
  }
  reader->Finish();
}

SubscriberCounts PoseSubscribers::total(SubscriberKind kind) const {
  SubscriberCounts sum;
  for (const SubscriberCounts& counts : each(kind)) {
    sum.received += counts.received;
    sum.missed += counts.missed;
    sum.streams += counts.streams;
    sum.streaming_seconds += counts.streaming_seconds;
  }
  return sum;
}

std::vector<SubscriberCounts> PoseSubscribers::each(SubscriberKind kind) const {
  std::vector<SubscriberCounts> counts;
  for (const auto& subscriber : subscribers_) {
    if (subscriber->kind != kind) continue;
    std::lock_guard<std::mutex> lock(subscriber->mutex);
    counts.push_back(subscriber->counts);
  }
  return counts;
}

}  // namespace mocap::soak
