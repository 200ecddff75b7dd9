// The web view: routes, the pose event stream and the controls.
#include "server/web_view.h"

#include <httplib.h>
#include <pthread.h>
#include <sched.h>

#include <charconv>
#include <chrono>
#include <fstream>
#include <future>
#include <sstream>
#include <string_view>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "drivers/thread_name.h"
#include "server/log.h"
#include "server/web_json.h"
#include "web/web_index_html.h"
#include "web/web_view_js.h"

namespace mocap {
namespace {

using nlohmann::json;

// Where Debian's libjs-three puts three.js (r111) and its non-module examples.
constexpr const char* kThreeDirectory = "/usr/share/javascript/three/";
// The server's threads: each open event stream holds one, so at most kMaxStreams of them stream
// and the rest serve pages, images, status and controls.
constexpr std::size_t kServerThreads = 24;
constexpr int kMaxStreams = 16;
constexpr const char* kThreadName = "mocapd-web";
// A camera's image is encoded at most this often (5 Hz), however many browsers ask.
constexpr auto kImageInterval = std::chrono::milliseconds(200);
// An idle event stream sends a comment this often, which also finds a browser that left.
constexpr auto kStreamKeepAlive = std::chrono::seconds(1);
constexpr std::string_view kWaiting = ": waiting\n\n";
// The controls answer when the pipeline has: a background capture of up to 1500 frames, a fit of
// up to 250 frame sets.
constexpr auto kControlTimeout = std::chrono::minutes(5);
// The status is read in microseconds; a pipeline that has not answered in this long is stuck, and
// the request answers 503 rather than hold its thread (the page asks again a second later).
constexpr auto kStatusTimeout = std::chrono::seconds(2);
// The RPCs' limits (server/mocap_service.cpp).
constexpr int kMaxBackgroundFrames = 1500;
constexpr int kDefaultBackgroundFrames = 25;
constexpr int kMaxFitFrameSets = 250;
constexpr int kDefaultFitFrameSets = 5;
// cpp-httplib 0.11 compresses each response typed text/*, or exactly "application/json" or
// "application/javascript", with Brotli at its highest quality on every request: 2.6 s of CPU for
// three.min.js, 10 ms for a status. These types, charset included, are sent as they are; the page
// (2 KB, once per load) is the one compressed. Loopback and a LAN gain nothing from compression.
constexpr const char* kJsonType = "application/json; charset=utf-8";
constexpr const char* kScriptType = "application/javascript; charset=utf-8";

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Every thread of the view names itself, so that `top -H` and tests/bench/web_cost.py tell its CPU
// from the tracker's, and runs at SCHED_IDLE: it gets only the time the cameras and the tracker
// leave, so browsers never delay a pose; on a saturated machine the view lags instead. A thread
// preempted at idle priority while holding a lock would hold up whoever waits for it, so the
// pipeline's hot paths never wait for a lock the view takes (WebView::offer, CameraImages::keep,
// PosePublisher::subscriberCount, RecordingControl::status, which the mask thread's recorder tap
// would otherwise wait for), and the status, which takes the pipeline's locks, is read on the
// status thread at the daemon's policy. Threads inherit their creator's policy, so the controls
// that start threads or wait for them (a recording's writers) run on the control thread, at the
// daemon's policy: a writer at idle priority barely runs on a saturated machine, and a recording's
// stop would wait minutes for it. A background capture and a body fit are handed to the mask
// thread there too, under locks it takes every frame set.
void becomeAViewThread() {
  nameThisThread(kThreadName);
  const sched_param no_priority{};
  pthread_setschedparam(pthread_self(), SCHED_IDLE, &no_priority);
}

// The server's pool: each thread becomes a view thread when it takes its first connection.
class NamedThreadPool final : public httplib::TaskQueue {
 public:
  explicit NamedThreadPool(std::size_t threads) : pool_(threads) {}
  void enqueue(std::function<void()> task) override {
    pool_.enqueue([task = std::move(task)] {
      thread_local const bool ready = (becomeAViewThread(), true);
      (void)ready;
      task();
    });
  }
  void shutdown() override { pool_.shutdown(); }

 private:
  httplib::ThreadPool pool_;
};

bool sameSecret(const std::string& a, const std::string& b) {
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size(); ++i)
    difference |= static_cast<unsigned char>(a[i] ^ (i < b.size() ? b[i] : 0));
  return difference == 0;
}

// The integer query parameter `name`, `fallback` when absent; nullopt when not an integer.
std::optional<int> intParam(const httplib::Request& request, const char* name, int fallback) {
  if (!request.has_param(name)) return fallback;
  const std::string text = request.get_param_value(name);
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

void reply(httplib::Response& response, int code, json body) {
  response.status = code;
  response.set_header("Cache-Control", "no-store");
  response.set_content(body.dump(), kJsonType);
}

void replyResult(httplib::Response& response, int code, const std::string& message,
                 json extra = json::object()) {
  extra["ok"] = code == 200;
  extra["message"] = message;
  reply(response, code, std::move(extra));
}

int httpCode(RecordingError error) {
  switch (error) {
    case RecordingError::kNone:
      return 200;
    case RecordingError::kBadPath:
      return 400;
    case RecordingError::kOutsideRoot:
      return 403;
    case RecordingError::kNotConfigured:
    case RecordingError::kBusy:
    case RecordingError::kNotRecording:
      return 409;
    case RecordingError::kIo:
      return 500;
  }
  return 500;
}

int httpCode(BackgroundError error) {
  switch (error) {
    case BackgroundError::kNone:
      return 200;
    case BackgroundError::kReplay:
    case BackgroundError::kBusy:
      return 409;
    case BackgroundError::kStalled:
      return 504;
    case BackgroundError::kStopped:
      return 503;
    case BackgroundError::kUnusable:
    case BackgroundError::kNotSaved:
      return 500;
  }
  return 500;
}

int httpCode(BodyFitError error) {
  switch (error) {
    case BodyFitError::kNone:
      return 200;
    case BodyFitError::kCannotFit:
    case BodyFitError::kCannotApply:
    case BodyFitError::kBusy:
    case BodyFitError::kNoSubject:
      return 409;
    case BodyFitError::kStalled:
      return 504;
    case BodyFitError::kStopped:
      return 503;
    case BodyFitError::kFailed:
      return 500;
  }
  return 500;
}

// Hands a pipeline request that answers through a callback (on a pipeline thread, or at once with
// a refusal) to the pipeline on `thread` with `submit`, and waits for the answer on this server
// thread; nullopt when none came within kControlTimeout of the call, the wait for `thread`
// included. What `submit` throws is thrown here, where httplib answers 500.
template <typename Result, typename Submit>
std::optional<Result> await(httplib::TaskQueue& thread, Submit submit) {
  const auto deadline = std::chrono::steady_clock::now() + kControlTimeout;
  auto answer = std::make_shared<std::promise<Result>>();
  std::future<Result> answered = answer->get_future();
  auto task =
      std::make_shared<std::packaged_task<void()>>([answer, submit = std::move(submit)]() mutable {
        submit([answer](const Result& result) { answer->set_value(result); });
      });
  std::future<void> submitted = task->get_future();
  thread.enqueue([task] { (*task)(); });
  if (submitted.wait_until(deadline) != std::future_status::ready) return std::nullopt;
  submitted.get();
  if (answered.wait_until(deadline) != std::future_status::ready) return std::nullopt;
  return answered.get();
}

// Runs `control` on `thread` and waits for its answer on this server thread; nullopt after
// kControlTimeout. What the control throws is thrown here, where httplib answers 500.
template <typename Control>
std::optional<std::invoke_result_t<Control>> onThread(httplib::TaskQueue& thread, Control control) {
  using Result = std::invoke_result_t<Control>;
  auto task = std::make_shared<std::packaged_task<Result()>>(std::move(control));
  std::future<Result> answer = task->get_future();
  thread.enqueue([task] { (*task)(); });
  if (answer.wait_for(kControlTimeout) != std::future_status::ready) return std::nullopt;
  return answer.get();
}

}  // namespace

WebView::WebView(const ServerConfig& config, Pipeline& pipeline, const Rig& rig,
                 PosePublisher& publisher)
    : config_(config),
      pipeline_(pipeline),
      rig_(rig),
      publisher_(publisher),
      images_(pipeline.cameras().size(), kImageInterval),
      server_(std::make_unique<httplib::Server>()) {
  server_->new_task_queue = [] { return new NamedThreadPool(kServerThreads); };
  // cpp-httplib binds with SO_REUSEPORT, so a second daemon's view would share the port without an
  // error: SO_REUSEADDR alone lets a restart rebind and refuses a port another socket listens on.
  server_->set_socket_options([](socket_t socket) {
    int yes = 1;
    setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  // Short, so idle browser connections give their thread back soon.
  server_->set_keep_alive_timeout(1);
  addRoutes();
  addControlRoutes();
}

WebView::~WebView() { stop(); }

Pipeline::MaskObserver WebView::maskObserver() {
  return [this](const FrameSet& set, const std::vector<SilhouetteMask>& masks) {
    images_.keep(set, masks);
  };
}

Status WebView::start() {
  const std::string& listen = config_.web.listen;
  const std::size_t colon = listen.rfind(':');
  std::string host = listen.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  int port = -1;
  const std::string port_text = listen.substr(colon + 1);
  std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (port == 0)
    port_ = server_->bind_to_any_port(host);
  else if (port > 0 && server_->bind_to_port(host, port))
    port_ = port;
  if (port_ <= 0)
    return Status::Error("web.listen: cannot listen on " + listen + " (address in use or invalid)");
  subscribed_ = publisher_.subscribe(this);
  control_thread_ = std::make_unique<httplib::ThreadPool>(1);
  control_thread_->enqueue([] { nameThisThread("mocapd-control"); });
  status_thread_ = std::make_unique<httplib::ThreadPool>(1);
  status_thread_->enqueue([] { nameThisThread("mocapd-status"); });
  listener_ = std::thread([this] {
    becomeAViewThread();
    server_->listen_after_bind();
  });
  return Status::Ok();
}

void WebView::stop() {
  {
    std::lock_guard lock(pose_mutex_);
    closing_ = true;
  }
  pose_changed_.notify_all();
  if (subscribed_) publisher_.unsubscribe(this);
  subscribed_ = false;
  if (listener_.joinable()) {
    server_->stop();
    listener_.join();
  }
  // After the server's threads: none can enqueue a control or a status read any more, and the
  // queued ones finish.
  if (control_thread_) control_thread_->shutdown();
  control_thread_.reset();
  if (status_thread_) status_thread_->shutdown();
  status_thread_.reset();
}

// On the publisher's thread, which never waits for the view: if a view thread holds the slot
// (it may be preempted there, at idle priority), this pose is not offered; the next one is.
void WebView::offer(const SharedPose& pose) {
  {
    std::unique_lock lock(pose_mutex_, std::try_to_lock);
    if (!lock) return;
    newest_pose_ = pose;
    ++poses_offered_;
  }
  pose_changed_.notify_all();
}

void WebView::finish() {
  {
    std::lock_guard lock(pose_mutex_);
    closing_ = true;
  }
  pose_changed_.notify_all();
}

// Each pose is drawn with the body it carries: Pipeline::trackedBody would take the fit job's lock,
// which the tracker takes to switch bodies, from this idle-priority thread.
std::shared_ptr<const std::string> WebView::poseEvent(const SharedPose& pose, uint64_t count) {
  std::lock_guard lock(event_mutex_);
  if (event_count_ != count) {
    newest_event_ = std::make_shared<const std::string>(
        "data: " + poseJson(*pose, {pose->body, pose->body_version}, rig_) + "\n\n");
    event_count_ = count;
  }
  return newest_event_;
}

std::shared_future<PipelineStatus> WebView::readPipelineStatus() {
  std::lock_guard lock(status_mutex_);
  const bool under_way = status_read_.valid() && status_read_.wait_for(std::chrono::seconds(0)) !=
                                                     std::future_status::ready;
  if (!under_way) {
    auto read = std::make_shared<std::packaged_task<PipelineStatus()>>([this] {
      if (status_read_observer_) status_read_observer_();
      return pipeline_.status();
    });
    status_read_ = read->get_future().share();
    status_thread_->enqueue([read] { (*read)(); });
  }
  return status_read_;
}

bool WebView::authorized(const httplib::Request& request, httplib::Response& response) const {
  if (config_.bearer_token.empty()) return true;
  const std::string header = request.get_header_value("Authorization");
  const std::string prefix = "Bearer ";
  // Browsers cannot put a header on an event stream or an image: those pass it as ?token=.
  const std::string given = header.rfind(prefix, 0) == 0 ? header.substr(prefix.size())
                                                         : request.get_param_value("token");
  if (!given.empty() && sameSecret(given, config_.bearer_token)) return true;
  replyResult(response, 401, "this daemon needs 'Authorization: Bearer <token>'");
  return false;
}

void WebView::addRoutes() {
  httplib::Server& server = *server_;
  server.Get("/", [](const httplib::Request&, httplib::Response& response) {
    response.set_content(kWebIndexHtml, "text/html; charset=utf-8");
  });
  server.Get("/view.js", [](const httplib::Request&, httplib::Response& response) {
    response.set_content(kWebViewJs, kScriptType);
  });
  // Only these two files of libjs-three, by fixed names: no request path reaches the file system.
  const std::pair<const char*, const char*> three_files[] = {
      {"/three/three.min.js", "build/three.min.js"},
      {"/three/OrbitControls.js", "examples/js/controls/OrbitControls.js"}};
  for (const auto& [route, file] : three_files) {
    const std::string path = std::string(kThreeDirectory) + file;
    server.Get(route, [path](const httplib::Request&, httplib::Response& response) {
      const std::string text = readFile(path);
      if (text.empty()) {
        response.status = 404;
        response.set_content(path + " is missing: install Debian's libjs-three", "text/plain");
        return;
      }
      response.set_header("Cache-Control", "max-age=3600");
      response.set_content(text, kScriptType);
    });
  }
  server.Get("/api/scene", [this](const httplib::Request& request, httplib::Response& response) {
    if (!authorized(request, response)) return;
    response.set_content(sceneJson(rig_, pipeline_.cameras()), kJsonType);
  });
  server.Get("/api/status", [this](const httplib::Request& request, httplib::Response& response) {
    if (!authorized(request, response)) return;
    const std::shared_future<PipelineStatus> status = readPipelineStatus();
    if (status.wait_for(kStatusTimeout) != std::future_status::ready)
      return replyResult(
          response, 503,
          "no status from the pipeline in " + std::to_string(kStatusTimeout.count()) + " s");
    int clients = 0;
    {
      std::lock_guard lock(pose_mutex_);
      clients = stream_clients_;
    }
    // The JSON is built here, at the view's priority: only the read needs the daemon's.
    response.set_header("Cache-Control", "no-store");
    response.set_content(statusJson(config_, status.get(), pipeline_.cameras(),
                                    publisher_.subscriberCount() - (subscribed_ ? 1 : 0),
                                    static_cast<std::size_t>(clients)),
                         kJsonType);
  });
  server.Get("/api/pose", [this](const httplib::Request& request, httplib::Response& response) {
    if (!authorized(request, response)) return;
    SharedPose pose;
    {
      std::lock_guard lock(pose_mutex_);
      pose = newest_pose_;
    }
    if (!pose) return replyResult(response, 503, "no pose yet");
    response.set_header("Cache-Control", "no-store");
    response.set_content(poseJson(*pose, {pose->body, pose->body_version}, rig_), kJsonType);
  });
  server.Get("/api/poses", [this](const httplib::Request& request, httplib::Response& response) {
    if (!authorized(request, response)) return;
    streamPoses(response);
  });
  server.Get(R"(/api/camera/(\d{1,3})\.jpg)",
             [this](const httplib::Request& request, httplib::Response& response) {
               if (!authorized(request, response)) return;
               const std::size_t camera = std::stoul(request.matches[1].str());
               if (camera >= pipeline_.cameras().size())
                 return replyResult(response, 404, "no such camera");
               const std::optional<std::string> jpeg = images_.jpeg(camera);
               if (!jpeg) return replyResult(response, 503, "no image yet");
               response.set_header("Cache-Control", "no-store");
               response.set_content(*jpeg, "image/jpeg");
             });
}

void WebView::streamPoses(httplib::Response& response) {
  {
    std::lock_guard lock(pose_mutex_);
    if (stream_clients_ >= kMaxStreams || closing_)
      return replyResult(response, 503, "too many pose streams open");
    ++stream_clients_;
  }
  response.set_header("Cache-Control", "no-store");
  auto last_sent = std::make_shared<uint64_t>(0);
  response.set_chunked_content_provider(
      "text/event-stream",
      [this, last_sent](std::size_t, httplib::DataSink& sink) {
        SharedPose pose;
        {
          std::unique_lock lock(pose_mutex_);
          pose_changed_.wait_for(lock, kStreamKeepAlive,
                                 [&] { return closing_ || poses_offered_ != *last_sent; });
          if (closing_) {
            lock.unlock();
            sink.done();
            return true;
          }
          if (poses_offered_ != *last_sent) {
            pose = newest_pose_;
            *last_sent = poses_offered_;
          }
        }
        if (!pose) return sink.write(kWaiting.data(), kWaiting.size());
        const std::shared_ptr<const std::string> event = poseEvent(pose, *last_sent);
        return sink.write(event->data(), event->size());
      },
      [this](bool) {
        std::lock_guard lock(pose_mutex_);
        --stream_clients_;
      });
}

void WebView::addControlRoutes() {
  httplib::Server& server = *server_;
  server.Post("/api/background", [this](const httplib::Request& request,
                                        httplib::Response& response) {
    if (!authorized(request, response)) return;
    const std::optional<int> frames = intParam(request, "frames", kDefaultBackgroundFrames);
    if (!frames || *frames < 1 || *frames > kMaxBackgroundFrames)
      return replyResult(response, 400,
                         "frames: from 1 to " + std::to_string(kMaxBackgroundFrames));
    const auto result =
        await<BackgroundResult>(*control_thread_, [this, frames = *frames](auto done) {
          if (control_observer_) control_observer_("background");
          logInfo() << "background capture of " << frames << " frames requested by the web view";
          pipeline_.captureBackground(frames, std::move(done));
        });
    if (!result) return replyResult(response, 504, "no answer from the pipeline");
    replyResult(response, httpCode(result->error), result->message,
                {{"frames_used", result->frames_used}, {"warnings", result->warnings}});
  });
  server.Post(
      "/api/fit-body", [this](const httplib::Request& request, httplib::Response& response) {
        if (!authorized(request, response)) return;
        const std::optional<int> frame_sets = intParam(request, "frame_sets", kDefaultFitFrameSets);
        if (!frame_sets || *frame_sets < 1 || *frame_sets > kMaxFitFrameSets)
          return replyResult(response, 400,
                             "frame_sets: from 1 to " + std::to_string(kMaxFitFrameSets));
        const bool apply = request.get_param_value("apply") == "1";
        const auto result = await<FitBodyResult>(
            *control_thread_, [this, frame_sets = *frame_sets, apply](auto done) {
              if (control_observer_) control_observer_("fit-body");
              logInfo() << "body fit from " << frame_sets << " frame sets"
                        << (apply ? ", applied," : "") << " requested by the web view";
              pipeline_.fitBody(frame_sets, apply, std::move(done));
            });
        if (!result) return replyResult(response, 504, "no answer from the pipeline");
        replyResult(response, httpCode(result->error), result->message,
                    {{"frame_sets_used", result->frame_sets_used},
                     {"fit_seconds", result->fit_seconds},
                     {"body_version", result->body_version}});
      });
  server.Post(
      "/api/recording/start", [this](const httplib::Request& request, httplib::Response& response) {
        if (!authorized(request, response)) return;
        std::string path = request.get_param_value("path");
        if (path.empty()) path = "web-" + std::to_string(std::time(nullptr));
        const auto result =
            onThread(*control_thread_, [this, path] { return pipeline_.startRecording(path); });
        if (!result) return replyResult(response, 504, "no answer from the pipeline");
        replyResult(response, httpCode(result->error), result->message,
                    {{"path", result->status.path}, {"active", result->status.active}});
      });
  server.Post("/api/recording/stop", [this](const httplib::Request& request,
                                            httplib::Response& response) {
    if (!authorized(request, response)) return;
    const auto result = onThread(*control_thread_, [this] { return pipeline_.stopRecording(); });
    if (!result) return replyResult(response, 504, "no answer from the pipeline");
    replyResult(response, httpCode(result->error), result->message,
                {{"path", result->status.path}, {"frame_sets", result->status.frame_sets}});
  });
  server.Post(
      "/api/reacquire", [this](const httplib::Request& request, httplib::Response& response) {
        if (!authorized(request, response)) return;
        switch (pipeline_.reacquire()) {
          case Pipeline::ReacquireError::kReplay:
            return replyResult(response, 409, "replay: the poses depend on the recording alone");
          case Pipeline::ReacquireError::kCannotPlace:
            return replyResult(response, 409, "this body's root cannot be placed");
          case Pipeline::ReacquireError::kNone:
            break;
        }
        logInfo() << "reacquisition requested by the web view";
        replyResult(response, 200, "finding the subject again");
      });
}

}  // namespace mocap
