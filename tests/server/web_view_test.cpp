// The web view served by a daemon on the fake hand scene, on loopback: the page and three.js, the
// status, each camera's JPEG, the pose event stream, refused paths, the bearer token, the view
// turned off, and the page in headless Chromium (when installed), whose screenshot must show the
// tracked outline over the subject and a rendered 3D view.
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "drivers/builtin_drivers.h"
#include "drivers/record/recorder.h"
#include "server/mocap_server.h"
#include "server/server_test_support.h"

// After Eigen (through the server's headers): <resolv.h>, which httplib includes, defines `_res`,
// a name Eigen's templates use.
#include <arpa/inet.h>
#include <fcntl.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

namespace mocap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kToken = "web-view-test-token-0123456789";

// The scene's daemon with its web view on (test::sceneConfig turns it off for the other suites).
std::unique_ptr<MocapServer> startServer(ServerConfig config) {
  config.web.enabled = true;
  config.web.listen = "127.0.0.1:0";
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  EXPECT_TRUE(server.ok()) << server.error();
  if (!server.ok()) return nullptr;
  EXPECT_TRUE(server.value()->start().ok());
  return std::move(server.value());
}

// The whole answer to `request` sent as is on a new connection (no client-side normalizing).
std::string rawRequest(int port, const std::string& request) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string answer;
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0) {
    (void)!write(fd, request.data(), request.size());
    char buffer[4096];
    ssize_t n = 0;
    while ((n = read(fd, buffer, sizeof buffer)) > 0) answer.append(buffer, n);
  }
  close(fd);
  return answer;
}

class WebViewTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { registerBuiltinDrivers(DriverRegistry::instance()); }

  void start(ServerConfig config = test::sceneConfig()) {
    server_ = startServer(std::move(config));
    ASSERT_TRUE(server_);
    ASSERT_GT(server_->webPort(), 0);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->webPort());
    client_->set_read_timeout(10, 0);
  }

  // Camera `camera`'s JPEG, asked for until the daemon has one (the first request starts the
  // keeping of frames).
  httplib::Result cameraImage(int camera, const httplib::Headers& headers = {}) {
    const std::string path = "/api/camera/" + std::to_string(camera) + ".jpg";
    httplib::Result result = client_->Get(path.c_str(), headers);
    for (int i = 0; i < 50 && result && result->status == 503; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      result = client_->Get(path.c_str(), headers);
    }
    return result;
  }

  std::unique_ptr<MocapServer> server_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(WebViewTest, ServesThePageAndThreeJs) {
  start();
  auto page = client_->Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("/three/three.min.js"), std::string::npos);
  auto script = client_->Get("/view.js");
  ASSERT_TRUE(script);
  EXPECT_EQ(script->status, 200);
  EXPECT_NE(script->body.find("EventSource"), std::string::npos);
  auto three = client_->Get("/three/three.min.js");
  ASSERT_TRUE(three);
  EXPECT_EQ(three->status, 200);
  EXPECT_NE(three->body.find("WebGLRenderer"), std::string::npos);
  auto orbit = client_->Get("/three/OrbitControls.js");
  ASSERT_TRUE(orbit);
  EXPECT_EQ(orbit->status, 200);
  EXPECT_NE(orbit->body.find("THREE.OrbitControls"), std::string::npos);
}

// cpp-httplib compresses text and JSON with Brotli at its slowest on every request unless told
// otherwise by the type: three.min.js took 2.6 s of the server's CPU per page load.
TEST_F(WebViewTest, ScriptsAndJsonAreSentUncompressed) {
  start();
  const httplib::Headers browser_accepts = {{"Accept-Encoding", "gzip, deflate, br"}};
  for (const char* path : {"/three/three.min.js", "/three/OrbitControls.js", "/view.js",
                           "/api/status", "/api/scene"}) {
    auto result = client_->Get(path, browser_accepts);
    ASSERT_TRUE(result) << path;
    EXPECT_EQ(result->status, 200) << path;
    EXPECT_EQ(result->get_header_value("Content-Encoding"), "") << path;
  }
}

TEST_F(WebViewTest, StatusAndScene) {
  start();
  auto status = client_->Get("/api/status");
  ASSERT_TRUE(status);
  ASSERT_EQ(status->status, 200);
  const json parsed = json::parse(status->body);
  EXPECT_EQ(parsed["mode"], "live");
  EXPECT_EQ(parsed["cameras"].size(), 2u);
  EXPECT_FALSE(parsed["token_required"].get<bool>());
  // The latency split by stage, as GetStatus gives it, in pipeline order.
  ASSERT_EQ(parsed["stage_latency_ms"].size(), 5u) << status->body;
  EXPECT_EQ(parsed["stage_latency_ms"][0]["stage"], "capture_to_silhouettes");
  EXPECT_EQ(parsed["stage_latency_ms"][3]["stage"], "track");
  auto scene = client_->Get("/api/scene");
  ASSERT_TRUE(scene);
  const json cameras = json::parse(scene->body)["cameras"];
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0]["width"], 780);
  EXPECT_EQ(cameras[0]["corner_rays"].size(), 4u);
}

// The silhouette's green tint (CameraImages::kTintBgr over the image): at least 51 greener than
// red or blue, less some JPEG error.
bool isSilhouette(const cv::Vec3b& bgr) {
  return bgr[1] > 60 && bgr[1] - std::max(bgr[0], bgr[2]) > 40;
}

// Each thread's name and scheduling policy, as `top -H` and `chrt -p` show them.
std::multimap<std::string, int> threadPolicies() {
  std::multimap<std::string, int> policies;
  for (const auto& task : fs::directory_iterator("/proc/self/task")) {
    std::ifstream comm(task.path() / "comm");
    std::string name;
    if (std::getline(comm, name))
      policies.emplace(name, sched_getscheduler(std::stoi(task.path().filename().string())));
  }
  return policies;
}

// The view's threads take only the time the pipeline leaves; the pipeline's keep their policy.
TEST_F(WebViewTest, TheViewsThreadsYieldToThePipeline) {
  start();
  ASSERT_TRUE(client_->Get("/api/status"));
  const std::multimap<std::string, int> policies = threadPolicies();
  EXPECT_GE(policies.count("mocapd-web"), 2u) << "the listener and the thread that answered";
  for (const auto& [name, policy] : policies) {
    if (name == "mocapd-web") {
      EXPECT_EQ(policy, SCHED_IDLE);
    } else if (name == "mocapd-track" || name == "mocapd-camera") {
      EXPECT_EQ(policy, SCHED_OTHER) << name;
    }
  }
}

// A recording started and stopped from the view is written at the daemon's policy: its writers
// inherit their creator's, and at the view's idle one they barely run on a busy machine, leaving
// the stop waiting for them.
TEST_F(WebViewTest, ARecordingsWritersKeepTheDaemonsPolicy) {
  ServerConfig config = test::sceneConfig();
  const fs::path root =
      fs::temp_directory_path() / ("mocap_web_policy_" + std::to_string(getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  config.recording_directory = root.string();
  start(config);
  auto started = client_->Post("/api/recording/start?path=policy_session");
  // Refused until every camera has sent a frame.
  for (int i = 0; i < 50 && started && started->status == 409; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    started = client_->Post("/api/recording/start?path=policy_session");
  }
  ASSERT_TRUE(started);
  ASSERT_EQ(started->status, 200) << started->body;
  const std::multimap<std::string, int> policies = threadPolicies();
  EXPECT_GE(policies.count(Recorder::kThreadName), 2u) << "the set and background writers";
  for (const auto& [name, policy] : policies) {
    if (name == Recorder::kThreadName || name == "mocapd-control") {
      EXPECT_EQ(policy, SCHED_OTHER) << name;
    }
  }
  auto stopped = client_->Post("/api/recording/stop");
  ASSERT_TRUE(stopped);
  EXPECT_EQ(stopped->status, 200) << stopped->body;
  server_->shutdown();
  fs::remove_all(root);
}

// Where the view read the pipeline's status, each time it did; and a gate that holds the reads
// while held, as a pipeline that does not answer would. Let go when destroyed, so that the view
// can stop however the test ends.
class StatusReads {
 public:
  struct Read {
    int policy;
    std::string thread;
  };

  explicit StatusReads(WebView& view) {
    view.setStatusReadObserver([state = state_] {
      char name[16] = {};
      pthread_getname_np(pthread_self(), name, sizeof name);
      std::unique_lock lock(state->mutex);
      state->reads.push_back({sched_getscheduler(0), name});
      state->changed.wait(lock, [&] { return !state->held; });
    });
  }
  ~StatusReads() { hold(false); }
  StatusReads(const StatusReads&) = delete;
  StatusReads& operator=(const StatusReads&) = delete;

  void hold(bool held) {
    std::lock_guard lock(state_->mutex);
    state_->held = held;
    state_->changed.notify_all();
  }
  std::vector<Read> all() const {
    std::lock_guard lock(state_->mutex);
    return state_->reads;
  }

 private:
  // Shared with the observer, which the view keeps after the test's object is gone.
  struct State {
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<Read> reads;
    bool held = false;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

// The status takes the pipeline's locks (the synchronizer's, the hand-offs', the meters'): read on
// a view thread at idle priority, one preempted inside them would hold up a camera or a stage.
TEST_F(WebViewTest, TheStatusIsReadAtTheDaemonsPolicy) {
  start();
  StatusReads status_reads(*server_->webView());
  auto status = client_->Get("/api/status");
  ASSERT_TRUE(status);
  ASSERT_EQ(status->status, 200);
  EXPECT_EQ(json::parse(status->body)["cameras"].size(), 2u);
  // Concurrent requests, each answered, each read on the same thread.
  std::vector<std::thread> browsers;
  std::vector<int> codes(6, 0);
  for (std::size_t i = 0; i < codes.size(); ++i) {
    browsers.emplace_back([this, &codes, i] {
      httplib::Client browser("127.0.0.1", server_->webPort());
      browser.set_read_timeout(10, 0);
      if (auto answer = browser.Get("/api/status")) codes[i] = answer->status;
    });
  }
  for (std::thread& browser : browsers) browser.join();
  for (int code : codes) EXPECT_EQ(code, 200);
  const std::vector<StatusReads::Read> reads = status_reads.all();
  ASSERT_GE(reads.size(), 2u);
  ASSERT_LE(reads.size(), 1 + codes.size());
  for (const StatusReads::Read& read : reads) {
    EXPECT_EQ(read.policy, SCHED_OTHER) << "read on " << read.thread;
    EXPECT_EQ(read.thread, "mocapd-status");
  }
  const std::multimap<std::string, int> policies = threadPolicies();
  ASSERT_EQ(policies.count("mocapd-status"), 1u);
  EXPECT_EQ(policies.find("mocapd-status")->second, SCHED_OTHER);
  server_->shutdown();
}

// A background capture and a body fit are queued for the mask thread under the background
// manager's and the fit job's locks, which it takes on every frame set: queued from a view thread
// at idle priority, one preempted inside them would hold the mask thread up. Each control keeps
// its answer.
TEST_F(WebViewTest, TheBackgroundAndFitControlsAreQueuedAtTheDaemonsPolicy) {
  start();
  struct Submission {
    std::string control;
    int policy;
    std::string thread;
  };
  // Shared with the observer, which the view keeps after the test's objects are gone.
  struct Submissions {
    std::mutex mutex;
    std::vector<Submission> all;
  };
  auto submissions = std::make_shared<Submissions>();
  server_->webView()->setControlObserver([submissions](const char* control) {
    char name[16] = {};
    pthread_getname_np(pthread_self(), name, sizeof name);
    std::lock_guard lock(submissions->mutex);
    submissions->all.push_back({control, sched_getscheduler(0), name});
  });
  auto background = client_->Post("/api/background?frames=1");
  ASSERT_TRUE(background);
  EXPECT_EQ(background->status, 200) << background->body;
  EXPECT_EQ(json::parse(background->body)["frames_used"], 1);
  // The hand scene's body has no fit pose: the fit job refuses it as it is queued.
  auto fit = client_->Post("/api/fit-body?frame_sets=1");
  ASSERT_TRUE(fit);
  EXPECT_EQ(fit->status, 409) << fit->body;
  EXPECT_NE(json::parse(fit->body)["message"].get<std::string>().find("fit_pose"),
            std::string::npos)
      << fit->body;
  std::lock_guard lock(submissions->mutex);
  ASSERT_EQ(submissions->all.size(), 2u);
  EXPECT_EQ(submissions->all[0].control, "background");
  EXPECT_EQ(submissions->all[1].control, "fit-body");
  for (const Submission& submission : submissions->all) {
    EXPECT_EQ(submission.policy, SCHED_OTHER)
        << submission.control << " queued on " << submission.thread;
    EXPECT_EQ(submission.thread, "mocapd-control") << submission.control;
  }
}

// A pipeline that does not give its status holds no request for good (503, after 2 s), nor piles
// up reads: the requests that come meanwhile share the read under way. The view still stops.
TEST_F(WebViewTest, AStatusThePipelineDoesNotGiveIsA503) {
  start();
  StatusReads status_reads(*server_->webView());
  status_reads.hold(true);
  std::vector<std::thread> browsers;
  std::vector<std::optional<std::pair<int, std::string>>> answers(3);
  for (std::size_t i = 0; i < answers.size(); ++i) {
    browsers.emplace_back([this, &answers, i] {
      httplib::Client browser("127.0.0.1", server_->webPort());
      browser.set_read_timeout(10, 0);
      if (auto answer = browser.Get("/api/status"))
        answers[i] = std::make_pair(answer->status, answer->body);
    });
  }
  for (std::thread& browser : browsers) browser.join();
  for (const auto& answer : answers) {
    ASSERT_TRUE(answer);
    EXPECT_EQ(answer->first, 503);
    const json body = json::parse(answer->second);
    EXPECT_FALSE(body["ok"].get<bool>());
    EXPECT_NE(body["message"].get<std::string>().find("no status from the pipeline"),
              std::string::npos)
        << answer->second;
  }
  status_reads.hold(false);
  auto status = client_->Get("/api/status");
  ASSERT_TRUE(status);
  EXPECT_EQ(status->status, 200);
  // The held read, and perhaps one for this request; one queued per request would be 4 by now.
  EXPECT_LE(status_reads.all().size(), 2u) << "the requests shared the read under way";
  server_->shutdown();
}

// Halved: the scene's 780x580 cameras are wider than the 640 pixels an image is sent at most; the
// silhouette is tinted on the subject, not over the whole image.
TEST_F(WebViewTest, AJpegPerCameraAtHalfTheCameraSize) {
  start();
  for (int camera = 0; camera < 2; ++camera) {
    auto image = cameraImage(camera);
    ASSERT_TRUE(image);
    ASSERT_EQ(image->status, 200);
    EXPECT_EQ(image->get_header_value("Content-Type"), "image/jpeg");
    const cv::Mat decoded =
        cv::imdecode(cv::Mat(1, static_cast<int>(image->body.size()), CV_8U, image->body.data()),
                     cv::IMREAD_COLOR);
    ASSERT_FALSE(decoded.empty());
    EXPECT_EQ(decoded.cols, 390);
    EXPECT_EQ(decoded.rows, 290);
    std::size_t tinted = 0;
    for (auto it = decoded.begin<cv::Vec3b>(); it != decoded.end<cv::Vec3b>(); ++it)
      tinted += isSilhouette(*it);
    EXPECT_GT(tinted, 100u) << camera;
    EXPECT_LT(tinted, decoded.total() / 4) << camera;
  }
  auto missing = client_->Get("/api/camera/2.jpg");
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
}

// The next `count` poses of a new event stream from the view on `port`, parsed.
std::vector<json> readPoseEvents(int port, int count) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(10, 0);
  std::vector<json> poses;
  std::string received;
  client.Get("/api/poses", [&](const char* data, std::size_t length) {
    received.append(data, length);
    std::size_t end;
    while ((end = received.find("\n\n")) != std::string::npos) {
      const std::string event = received.substr(0, end);
      received.erase(0, end + 2);
      if (event.rfind("data: ", 0) == 0) poses.push_back(json::parse(event.substr(6)));
    }
    return static_cast<int>(poses.size()) < count;
  });
  return poses;
}

TEST_F(WebViewTest, EventStreamDeliversPoses) {
  start();
  const std::vector<json> poses = readPoseEvents(server_->webPort(), 5);
  ASSERT_EQ(poses.size(), 5u);
  for (const json& pose : poses) {
    EXPECT_FALSE(pose["points"].empty());
    EXPECT_FALSE(pose["lines"].empty());
    EXPECT_EQ(pose["projected"].size(), 2u);
    EXPECT_EQ(pose["projected"][0].size(), pose["points"].size());
  }
}

// The streams share each pose's serialized event: two browsers open at once get, for every frame
// set both saw, the same pose (a shared event mixed up between poses would differ).
TEST_F(WebViewTest, TwoEventStreamsShareEachPose) {
  start();
  std::vector<json> first, second;
  std::thread other([&] { second = readPoseEvents(server_->webPort(), 25); });
  first = readPoseEvents(server_->webPort(), 25);
  other.join();
  ASSERT_EQ(first.size(), 25u);
  ASSERT_EQ(second.size(), 25u);
  std::map<uint64_t, std::string> by_frame;
  for (const json& pose : first) by_frame[pose["frame_sequence"].get<uint64_t>()] = pose.dump();
  int shared = 0;
  for (const json& pose : second) {
    const auto same = by_frame.find(pose["frame_sequence"].get<uint64_t>());
    if (same == by_frame.end()) continue;
    EXPECT_EQ(pose.dump(), same->second);
    ++shared;
  }
  EXPECT_GT(shared, 0);  // both streams were open over the same second
}

TEST_F(WebViewTest, UnknownPathsAndTraversalAreRefused) {
  start();
  for (const char* path : {"/nope", "/api/nope", "/three/three.js", "/web/index.html"}) {
    auto result = client_->Get(path);
    ASSERT_TRUE(result);
    EXPECT_EQ(result->status, 404) << path;
  }
  for (const std::string path :
       {"/../../../../etc/passwd", "/three/../../../../../etc/passwd",
        "/%2e%2e/%2e%2e/%2e%2e/etc/passwd", "/three/%2e%2e/%2e%2e/%2e%2e/%2e%2e/etc/passwd",
        "/three/..%2f..%2f..%2fbuild/three.min.js", "/three/../build/three.min.js"}) {
    const std::string answer = rawRequest(
        server_->webPort(), "GET " + path + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    ASSERT_FALSE(answer.empty()) << path;
    EXPECT_EQ(answer.find("HTTP/1.1 200"), std::string::npos)
        << path << ": " << answer.substr(0, 80);
    EXPECT_EQ(answer.find("root:"), std::string::npos) << path;
  }
}

TEST_F(WebViewTest, TheTokenIsRequiredWhenConfigured) {
  ServerConfig config = test::sceneConfig();
  config.bearer_token = kToken;
  start(config);
  EXPECT_EQ(client_->Get("/")->status, 200);  // the page itself asks for the token
  EXPECT_EQ(client_->Post("/api/reacquire")->status, 401);
  EXPECT_EQ(client_->Post("/api/recording/start")->status, 401);
  EXPECT_EQ(client_->Post("/api/background")->status, 401);
  EXPECT_EQ(client_->Get("/api/status")->status, 401);
  EXPECT_EQ(client_->Get("/api/camera/0.jpg")->status, 401);
  const httplib::Headers wrong = {{"Authorization", "Bearer not-the-token-at-all-000"}};
  EXPECT_EQ(client_->Post("/api/reacquire", wrong, "", "text/plain")->status, 401);
  const httplib::Headers right = {{"Authorization", std::string("Bearer ") + kToken}};
  // The hand's root cannot be placed: refused by the pipeline, past the token.
  EXPECT_EQ(client_->Post("/api/reacquire", right, "", "text/plain")->status, 409);
  EXPECT_EQ(client_->Get("/api/status", right)->status, 200);
  EXPECT_EQ(client_->Get((std::string("/api/status?token=") + kToken).c_str())->status, 200);
  auto image = cameraImage(0, right);
  ASSERT_TRUE(image);
  EXPECT_EQ(image->status, 200);
}

TEST_F(WebViewTest, ControlsCallThePipeline) {
  ServerConfig config = test::sceneConfig();
  const fs::path root = fs::temp_directory_path() / ("mocap_web_" + std::to_string(getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  config.recording_directory = root.string();
  start(config);
  EXPECT_EQ(client_->Post("/api/background?frames=0")->status, 400);
  EXPECT_EQ(client_->Post("/api/fit-body?frame_sets=999")->status, 400);
  EXPECT_EQ(client_->Post("/api/recording/start?path=../out")->status, 400);  // ".." refused
  std::this_thread::sleep_for(std::chrono::seconds(1));  // every camera has sent a frame
  auto started = client_->Post("/api/recording/start?path=web_session");
  ASSERT_TRUE(started);
  EXPECT_EQ(started->status, 200) << started->body;
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  auto stopped = client_->Post("/api/recording/stop");
  ASSERT_TRUE(stopped);
  EXPECT_EQ(stopped->status, 200) << stopped->body;
  EXPECT_GT(json::parse(stopped->body)["frame_sets"].get<int>(), 0);
  EXPECT_TRUE(fs::exists(root / "web_session"));
  EXPECT_EQ(client_->Post("/api/recording/stop")->status, 409);
  server_->shutdown();
  fs::remove_all(root);
}

// A second daemon cannot take a port a view already listens on (cpp-httplib's own sockets would let
// it share the port): it runs without its view, with a warning, and the first view answers.
TEST_F(WebViewTest, ASecondViewOnTheSamePortIsRefused) {
  start();
  ServerConfig config = test::sceneConfig();
  config.web.enabled = true;
  config.web.listen = "127.0.0.1:" + std::to_string(server_->webPort());
  Expected<std::unique_ptr<MocapServer>> second = MocapServer::create(config);
  ASSERT_TRUE(second.ok()) << second.error();
  ASSERT_TRUE(second.value()->start().ok());
  EXPECT_EQ(second.value()->webPort(), 0);
  auto status = client_->Get("/api/status");
  ASSERT_TRUE(status);
  EXPECT_EQ(status->status, 200);
}

TEST_F(WebViewTest, DisabledServesNothing) {
  // A port free now, which the daemon would take if the view were on.
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length), 0);
  const int port = ntohs(address.sin_port);
  close(fd);
  ServerConfig config =
      parseConfig(std::string(kDefaultConfigYaml) +
                      "web: {enabled: false, listen: 127.0.0.1:" + std::to_string(port) + "}\n",
                  "<test>", ".");
  config.listen = "127.0.0.1:0";
  config.log_level = LogLevel::kWarning;
  EXPECT_FALSE(config.web.enabled);
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  ASSERT_TRUE(server.ok()) << server.error();
  ASSERT_TRUE(server.value()->start().ok());
  EXPECT_EQ(server.value()->webPort(), 0);
  httplib::Client client("127.0.0.1", port);
  client.set_connection_timeout(1, 0);
  EXPECT_FALSE(client.Get("/"));
}

// Headless Chromium, as Debian ships it; empty when not installed.
std::string chromium() {
  for (const char* path : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (fs::exists(path)) return path;
  return "";
}

// The DevTools protocol sends the screenshot's PNG as base64.
std::string decodeBase64(const std::string& text) {
  std::string bytes;
  uint32_t bits = 0;
  int count = 0;
  for (const char c : text) {
    const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const char* at = std::strchr(digits, c);
    if (c == '=' || c == '\0' || !at) continue;
    bits = bits << 6 | static_cast<uint32_t>(at - digits);
    if ((count += 6) >= 8) bytes.push_back(static_cast<char>(bits >> (count -= 8) & 0xff));
  }
  return bytes;
}

// Headless Chromium driven over the DevTools protocol on a pipe (--remote-debugging-pipe: the
// browser reads commands on descriptor 3 and answers on 4, each message ended by a NUL). The test
// takes its screenshot once the page shows what it checks; `--screenshot` takes it at the load
// event, before the page's script has fetched an image, a pose or the status.
class HeadlessChromium {
 public:
  // Software WebGL: SwiftShader, which headless Chromium allows with the unsafe flag. The
  // browser's output goes to `dir`/chromium.log.
  HeadlessChromium(const std::string& browser, const fs::path& dir) {
    std::signal(SIGPIPE, SIG_IGN);  // a browser that died answers a write with EPIPE instead
    std::vector<std::string> arguments = {browser,
                                          "--headless",
                                          "--no-sandbox",
                                          "--disable-gpu",
                                          "--no-first-run",
                                          "--disable-background-networking",
                                          "--disable-component-update",
                                          "--disable-sync",
                                          "--use-gl=angle",
                                          "--use-angle=swiftshader",
                                          "--enable-unsafe-swiftshader",
                                          "--remote-debugging-pipe",
                                          "--user-data-dir=" + (dir / "profile").string(),
                                          "about:blank"};
    std::vector<char*> argv;
    for (std::string& argument : arguments) argv.push_back(argument.data());
    argv.push_back(nullptr);
    int commands[2], answers[2];
    if (pipe2(commands, O_CLOEXEC) != 0 || pipe2(answers, O_CLOEXEC) != 0) return;
    const int log = ::open((dir / "chromium.log").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_ = fork();
    if (pid_ == 0) {
      // Moved above 4 first, so that placing one on 3 or 4 cannot close the other.
      const int in = fcntl(commands[0], F_DUPFD, 10), out = fcntl(answers[1], F_DUPFD, 10);
      dup2(in, 3);
      dup2(out, 4);
      dup2(log, 1);
      dup2(log, 2);
      setpgid(0, 0);  // its own group: the browser's helper processes end with it
      execv(argv[0], argv.data());
      _exit(127);
    }
    close(commands[0]);
    close(answers[1]);
    close(log);
    to_browser_ = commands[1];
    from_browser_ = answers[0];
  }

  ~HeadlessChromium() {
    if (pid_ <= 0) return;
    call("Browser.close", json::object(), "", std::chrono::seconds(5));
    close(to_browser_);
    int status = 0;
    for (int wait = 0; wait < 100 && waitpid(pid_, &status, WNOHANG) == 0; ++wait)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (waitpid(pid_, &status, WNOHANG) == 0) {
      kill(-pid_, SIGKILL);
      waitpid(pid_, &status, 0);
    }
    close(from_browser_);
  }

  bool started() const { return pid_ > 0; }
  const std::string& lastError() const { return last_error_; }

  // `method`'s result, or nullopt when it failed (lastError() says why).
  std::optional<json> call(const std::string& method, json params = json::object(),
                           const std::string& session = "",
                           std::chrono::seconds timeout = std::chrono::seconds(30)) {
    json message = {{"id", ++last_id_}, {"method", method}, {"params", std::move(params)}};
    if (!session.empty()) message["sessionId"] = session;
    const std::string text = message.dump() + '\0';
    if (write(to_browser_, text.data(), text.size()) != static_cast<ssize_t>(text.size())) {
      last_error_ = method + ": the browser is gone";
      return std::nullopt;
    }
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      std::size_t end = 0;
      while ((end = received_.find('\0')) == std::string::npos) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        pollfd readable{from_browser_, POLLIN, 0};
        char buffer[65536];
        const ssize_t n = left.count() > 0 && poll(&readable, 1, static_cast<int>(left.count())) > 0
                              ? read(from_browser_, buffer, sizeof buffer)
                              : 0;
        if (n <= 0) {
          last_error_ = method + ": no answer";
          return std::nullopt;
        }
        received_.append(buffer, static_cast<std::size_t>(n));
      }
      const json answer = json::parse(received_.substr(0, end), nullptr, false);
      received_.erase(0, end + 1);
      if (!answer.is_object() || answer.value("id", 0) != last_id_) continue;  // an event
      if (answer.contains("error")) {
        last_error_ = method + ": " + answer["error"].dump();
        return std::nullopt;
      }
      return answer["result"];
    }
  }

  // A new page of `width`×`height` pixels loading `url`; its session, empty on failure.
  std::string open(const std::string& url, int width, int height) {
    const auto target = call("Target.createTarget", {{"url", "about:blank"}});
    if (!target) return "";
    const auto attached =
        call("Target.attachToTarget", {{"targetId", (*target)["targetId"]}, {"flatten", true}});
    if (!attached) return "";
    const std::string session = (*attached)["sessionId"];
    const bool opened =
        call("Emulation.setDeviceMetricsOverride",
             {{"width", width}, {"height", height}, {"deviceScaleFactor", 1}, {"mobile", false}},
             session) &&
        call("Page.navigate", {{"url", url}}, session);
    return opened ? session : "";
  }

  // The value of a JavaScript expression in the page; null when it threw.
  json evaluate(const std::string& session, const std::string& expression) {
    const auto result =
        call("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}}, session);
    if (!result || result->contains("exceptionDetails")) return nullptr;
    return (*result)["result"].value("value", json());
  }

  // What the page shows now, as BGR pixels; empty on failure.
  cv::Mat screenshot(const std::string& session) {
    const auto result = call("Page.captureScreenshot", {{"format", "png"}}, session);
    if (!result) return {};
    const std::string png = decodeBase64((*result)["data"].get<std::string>());
    return cv::imdecode(
        cv::Mat(1, static_cast<int>(png.size()), CV_8U, const_cast<char*>(png.data())),
        cv::IMREAD_COLOR);
  }

 private:
  pid_t pid_ = -1;
  int to_browser_ = -1;
  int from_browser_ = -1;
  int last_id_ = 0;
  std::string received_;
  std::string last_error_;
};

// Pure enough magenta: the outline the page draws over the camera images.
bool isOutline(const cv::Vec3b& bgr) { return bgr[2] > 170 && bgr[0] > 170 && bgr[1] < 100; }

// The page's own state: each camera's canvas shows an image with the outline over it, the 3D view
// exists and had a pose, the status table has a row per camera.
constexpr const char* kPageState = R"(JSON.stringify({
  cameras: cameraViews.map(v => v.shows || null),
  world: !!world.renderer, pose: latestPose !== null,
  status_rows: document.querySelectorAll('#camera-status tr').length,
  summary: document.getElementById('summary').textContent}))";
constexpr const char* kPageShowsAll = R"(cameraViews.length === 2 &&
  cameraViews.every(v => v.shows && v.shows.image && v.shows.outline) && !!world.renderer &&
  latestPose !== null && document.querySelectorAll('#camera-status tr').length === 3 &&
  document.getElementById('summary').textContent.includes('by stage (p50/p99 ms) capture_to'))";

TEST_F(WebViewTest, ChromiumShowsTheOutlineOverTheSubjectAndThe3dView) {
  const std::string browser = chromium();
  if (browser.empty()) GTEST_SKIP() << "chromium is not installed (deploy/install-deps)";
  start();
  const fs::path dir =
      fs::temp_directory_path() / ("mocap_web_chromium_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "profile");
  cv::Mat image;
  {
    HeadlessChromium chromium(browser, dir);
    ASSERT_TRUE(chromium.started());
    const std::string page =
        chromium.open("http://127.0.0.1:" + std::to_string(server_->webPort()) + "/", 1280, 900);
    ASSERT_FALSE(page.empty()) << chromium.lastError() << "; see " << (dir / "chromium.log");
    // Usually within 2 s; the bound only ends a test whose page never gets there.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    bool shows_all = false;
    while (!(shows_all = chromium.evaluate(page, kPageShowsAll) == true) &&
           std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_TRUE(shows_all) << chromium.evaluate(page, kPageState);
    image = chromium.screenshot(page);
    ASSERT_FALSE(image.empty()) << chromium.lastError();
  }
  if (const char* keep = std::getenv("MOCAP_WEB_SCREENSHOT")) cv::imwrite(keep, image);

  // The camera images fill the left 780 pixels: the outline must be there and lie on the tinted
  // silhouette (within a few pixels, the width of the drawn line).
  constexpr int kNear = 6;
  int outline = 0, over_subject = 0;
  for (int y = kNear; y < 420; ++y) {
    for (int x = kNear; x < 780; ++x) {
      if (!isOutline(image.at<cv::Vec3b>(y, x))) continue;
      ++outline;
      bool near = false;
      for (int dy = -kNear; dy <= kNear && !near; ++dy)
        for (int dx = -kNear; dx <= kNear && !near; ++dx)
          near = isSilhouette(image.at<cv::Vec3b>(y + dy, x + dx));
      over_subject += near;
    }
  }
  EXPECT_GT(outline, 50);
  EXPECT_GT(over_subject, 0.8 * outline) << over_subject << " of " << outline;

  // The 3D view (right of the cameras) rendered something other than its clear colour.
  const cv::Vec3b clear(0x28, 0x24, 0x20);
  int drawn = 0, black = 0;
  for (int y = 60; y < 420; ++y) {
    for (int x = 820; x < 1240; ++x) {
      const cv::Vec3b pixel = image.at<cv::Vec3b>(y, x);
      drawn += cv::norm(cv::Vec3i(pixel) - cv::Vec3i(clear)) > 40;
      black += pixel == cv::Vec3b(0, 0, 0);
    }
  }
  EXPECT_GT(drawn, 300) << "the WebGL canvas looks blank";
  EXPECT_LT(black, 420 * 360 / 2) << "no WebGL: the canvas stayed black";
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(WebConfigTest, KeysAreChecked) {
  const ServerConfig plain = parseConfig(kDefaultConfigYaml, "<test>", ".");
  EXPECT_TRUE(plain.web.enabled);
  EXPECT_EQ(plain.web.listen, "127.0.0.1:8080");
  const ServerConfig moved =
      parseConfig(std::string(kDefaultConfigYaml) + "web: {listen: 127.0.0.1:9000}\n", "<t>", ".");
  EXPECT_EQ(moved.web.listen, "127.0.0.1:9000");
  EXPECT_THROW(parseConfig(std::string(kDefaultConfigYaml) + "web: {port: 9000}\n", "<t>", "."),
               ConfigError);
  EXPECT_THROW(
      parseConfig(std::string(kDefaultConfigYaml) + "web: {listen: nowhere}\n", "<t>", "."),
      ConfigError);
}

}  // namespace
}  // namespace mocap
