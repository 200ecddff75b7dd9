// The web view the daemon serves (loopback by default): a page showing each camera's image with
// its silhouette and the tracked model's outline, a 3D view (three.js), the status and the
// controls. One cpp-httplib server with its own fixed thread pool, started and stopped by
// MocapServer. Its controls call the pipeline's components as the gRPC service does, behind the
// same bearer token.
//
// A slow browser loses poses and images, never slows the tracker or the gRPC subscribers: the
// view is one publisher subscriber holding only the newest pose (latest wins), each event-stream
// client waits for a newer one on its own server thread (each pose serialized once, by the first
// stream to send it), and images are encoded on the server's threads from the newest frame set, at
// most 5 times a second per camera.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "drivers/status.h"
#include "server/config.h"
#include "server/pipeline.h"
#include "server/pose_publisher.h"
#include "server/web_images.h"
#include "tracker/model/camera.h"

namespace httplib {
class Server;
class TaskQueue;
class Request;
class Response;
}  // namespace httplib

namespace mocap {

class WebView final : public PoseSubscriber {
 public:
  // Everything is borrowed and must outlive the view.
  WebView(const ServerConfig& config, Pipeline& pipeline, const Rig& rig, PosePublisher& publisher);
  ~WebView() override;
  WebView(const WebView&) = delete;
  WebView& operator=(const WebView&) = delete;

  // Binds config.web.listen and starts serving; the error names the address.
  Status start();
  // Ends the event streams, stops the server and joins its threads. Idempotent.
  void stop();
  int port() const { return port_; }
  // For Pipeline::setMaskObserver: keeps the newest images for the page.
  Pipeline::MaskObserver maskObserver();

  // PoseSubscriber: the publisher thread offers each pose; it only replaces the newest one.
  void offer(const SharedPose& pose) override;
  void finish() override;

  // A seam for tests: called on the thread that reads the pipeline's status, just before it reads
  // it. Set it before the first status request.
  void setStatusReadObserver(std::function<void()> observer) {
    status_read_observer_ = std::move(observer);
  }
  // A seam for tests: called on the thread that hands a background capture ("background") or a
  // body fit ("fit-body") to the pipeline, just before it does. Set it before the first control.
  void setControlObserver(std::function<void(const char* control)> observer) {
    control_observer_ = std::move(observer);
  }

 private:
  void addRoutes();
  void addControlRoutes();
  // An event stream of the newest poses, for one browser.
  void streamPoses(httplib::Response& response);
  // The event of pose number `count`, serialized by the first stream that asks for it.
  std::shared_ptr<const std::string> poseEvent(const SharedPose& pose, uint64_t count);
  // The pipeline's status, read on the status thread. A request that comes while a read is under
  // way shares that read rather than queueing another: concurrent requests cost one read, and a
  // pipeline that does not answer holds up at most one task.
  std::shared_future<PipelineStatus> readPipelineStatus();
  // False (and the response filled with 401) when a token is configured and the request does
  // not carry it ("Authorization: Bearer <token>").
  bool authorized(const httplib::Request& request, httplib::Response& response) const;

  const ServerConfig& config_;
  Pipeline& pipeline_;
  const Rig& rig_;
  PosePublisher& publisher_;
  CameraImages images_;
  std::unique_ptr<httplib::Server> server_;
  std::thread listener_;
  // Runs the controls' work on the pipeline (recording start and stop, handing a background
  // capture or a body fit to the mask thread), at the daemon's policy: what a control starts
  // inherits its caller's policy, which must not be the view's idle one, and the locks a request
  // is queued under (the background manager's, the fit job's, the recording's) are taken by the
  // mask thread every frame set, which a view thread preempted inside one would hold up. Started
  // by start(), on the daemon's thread.
  std::unique_ptr<httplib::TaskQueue> control_thread_;
  // Reads the pipeline's status for /api/status (mocapd-status), at the daemon's policy: the
  // status takes the pipeline's own locks (the synchronizer's, the hand-offs', the meters'), which
  // a view thread preempted at idle priority would hold while a camera or a stage waits. Its own
  // thread, so that a recording's stop on the control thread (seconds) does not delay it. Started
  // by start(), on the daemon's thread.
  std::unique_ptr<httplib::TaskQueue> status_thread_;
  std::function<void()> status_read_observer_;
  std::function<void(const char*)> control_observer_;
  int port_ = 0;
  bool subscribed_ = false;

  // The newest pose and its count, for the event streams (latest wins).
  mutable std::mutex pose_mutex_;
  std::condition_variable pose_changed_;
  SharedPose newest_pose_;
  uint64_t poses_offered_ = 0;
  bool closing_ = false;
  int stream_clients_ = 0;

  // The newest pose's event, shared by the streams.
  std::mutex event_mutex_;
  std::shared_ptr<const std::string> newest_event_;
  uint64_t event_count_ = 0;

  // The status read under way or last done, shared by the requests that come meanwhile.
  std::mutex status_mutex_;
  std::shared_future<PipelineStatus> status_read_;
};

}  // namespace mocap
