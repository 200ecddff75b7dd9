// The libcamera Camera: configuration, requests and buffers, the worker thread, frame bookkeeping
// and reopen-with-backoff.
//
// libcamera emits requestCompleted and disconnected on its own camera-manager thread, which also
// runs the pipeline handler: converting a frame or calling the sink there would hold up every
// camera's completions, and tearing the camera down from inside its own signal is not allowed. So
// the slots only queue the request (or the flag) and wake a worker thread, which converts,
// re-queues, delivers, and owns the camera for closing and reopening; its bounded wait keeps stop()
// prompt.
#include "drivers/libcamera/libcamera_camera.h"

#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <span>
#include <utility>
#include <vector>

#include <libcamera/libcamera.h>

#include "drivers/libcamera/libcamera_device.h"
#include "drivers/libcamera/libcamera_settings.h"
#include "drivers/thread_name.h"

namespace mocap {

struct LibcameraSession {
  std::shared_ptr<libcamera::Camera> camera;
  std::unique_ptr<libcamera::CameraConfiguration> configuration;
  libcamera::Stream* stream = nullptr;
  size_t stride = 0;
  libcamera::ControlList start_controls;
  std::unique_ptr<libcamera::FrameBufferAllocator> allocator;
  std::vector<std::unique_ptr<libcamera::Request>> requests;
  // Each buffer's planes, mapped once when the buffers are allocated.
  std::map<const libcamera::FrameBuffer*, std::vector<std::span<const uint8_t>>> planes;
  std::vector<std::pair<void*, size_t>> mappings;
  bool acquired = false;
  bool connected = false;
  bool started = false;

  void unmapAll() {
    planes.clear();
    for (const auto& [address, length] : mappings) munmap(address, length);
    mappings.clear();
  }
  ~LibcameraSession() { unmapAll(); }
};

namespace {

// Maps every dmabuf of the buffer once (planes often share one fd at different offsets).
Status mapBuffer(LibcameraSession& session, const libcamera::FrameBuffer& buffer) {
  std::map<int, size_t> lengths;
  for (const libcamera::FrameBuffer::Plane& plane : buffer.planes()) {
    if (plane.offset == libcamera::FrameBuffer::Plane::kInvalidOffset) {
      return Status::Error("a buffer plane has no offset");
    }
    size_t& length = lengths[plane.fd.get()];
    length = std::max<size_t>(length, size_t{plane.offset} + plane.length);
  }
  std::map<int, const uint8_t*> bases;
  for (const auto& [fd, length] : lengths) {
    void* address = mmap(nullptr, length, PROT_READ, MAP_SHARED, fd, 0);
    if (address == MAP_FAILED) return Status::Error(std::string("mmap: ") + std::strerror(errno));
    session.mappings.emplace_back(address, length);
    bases[fd] = static_cast<const uint8_t*>(address);
  }
  std::vector<std::span<const uint8_t>>& planes = session.planes[&buffer];
  for (const libcamera::FrameBuffer::Plane& plane : buffer.planes()) {
    planes.emplace_back(bases[plane.fd.get()] + plane.offset, plane.length);
  }
  return Status::Ok();
}

}  // namespace

uint32_t libcameraFramesLost(uint32_t previous, uint32_t current) {
  const uint32_t gap = current - previous - 1;
  return gap < (1u << 31) ? gap : 0;
}

Status checkLibcameraConfig(const CameraConfig& config) {
  const std::string label =
      "libcamera: camera " + (config.device.empty() ? "(first)" : "'" + config.device + "'");
  if (config.trigger != TriggerMode::kFreeRun) {
    return Status::Error(label + ": trigger mode " +
                         (config.trigger == TriggerMode::kSoftware ? "software" : "hardware line") +
                         " is not supported: libcamera has no trigger control; use free-run");
  }
  if (config.width <= 0 || config.height <= 0) {
    return Status::Error(label + ": size " + std::to_string(config.width) + "x" +
                         std::to_string(config.height) +
                         " is not possible: width and height must be positive");
  }
  if (!(config.fps > 0)) {
    return Status::Error(label + ": fps " + lc::numberText(config.fps) +
                         " is not possible: it must be positive");
  }
  if (config.exposure_us && !(*config.exposure_us > 0)) {
    return Status::Error(label + ": exposure_us " + lc::numberText(*config.exposure_us) +
                         " is not possible: it must be positive");
  }
  if (!config.pixel_format.empty() && !libcameraFormatFromName(config.pixel_format)) {
    return Status::Error(label + ": pixel format '" + config.pixel_format +
                         "' is not supported by mocapd; use one of " +
                         convertibleLibcameraFormatList());
  }
  return Status::Ok();
}

LibcameraCamera::LibcameraCamera(const CameraConfig& config, const LibcameraOptions& options,
                                 std::shared_ptr<libcamera::CameraManager> manager)
    : config_(config), options_(options), manager_(std::move(manager)) {}

Expected<std::unique_ptr<LibcameraCamera>> LibcameraCamera::open(
    const CameraConfig& config, const LibcameraOptions& options,
    std::shared_ptr<libcamera::CameraManager> manager) {
  if (Status status = checkLibcameraConfig(config); !status.ok()) return status;
  std::unique_ptr<LibcameraCamera> camera(new LibcameraCamera(config, options, std::move(manager)));
  if (Status status = camera->openSession(); !status.ok()) return status;
  return camera;
}

LibcameraCamera::~LibcameraCamera() {
  stop();
  closeSession();
}

Status LibcameraCamera::openSession() {
  const bool first_open = camera_id_.empty();
  Expected<std::shared_ptr<libcamera::Camera>> found =
      lc::findCamera(*manager_, first_open ? config_.device : camera_id_);
  if (!found.ok()) return Status::Error(found.error());
  auto session = std::make_unique<LibcameraSession>();
  session->camera = found.value();
  const std::string label = "libcamera: camera " + session->camera->id();
  if (const int ret = session->camera->acquire(); ret < 0) {
    return Status::Error(label + ": acquire: " + lc::errorText(ret) +
                         (ret == -EBUSY ? " (another application is using it)" : ""));
  }
  session->acquired = true;
  if (first_open) camera_id_ = session->camera->id();
  session_ = std::move(session);
  if (Status status = configure(*session_); !status.ok()) {
    if (first_open) camera_id_.clear();
    closeSession();
    return status;
  }
  return Status::Ok();
}

Status LibcameraCamera::configure(LibcameraSession& session) {
  libcamera::Camera& camera = *session.camera;
  const bool first_open = fourcc_ == 0;
  const std::string label = "libcamera: camera " + camera_id_;

  session.configuration = camera.generateConfiguration({libcamera::StreamRole::VideoRecording});
  if (!session.configuration || session.configuration->empty()) {
    return Status::Error(label + ": offers no video recording stream");
  }
  libcamera::StreamConfiguration& stream_config = session.configuration->at(0);
  const libcamera::StreamFormats formats = stream_config.formats();
  std::string offered_text;
  for (const libcamera::PixelFormat& format : formats.pixelformats()) {
    offered_text += (offered_text.empty() ? "" : ", ") + format.toString();
  }
  const unsigned int width = first_open ? config_.width : info_.modes.front().width;
  const unsigned int height = first_open ? config_.height : info_.modes.front().height;
  const libcamera::Size wanted_size(width, height);
  uint32_t fourcc = fourcc_;
  if (first_open) {
    const Expected<uint32_t> chosen =
        lc::choosePixelFormat(config_, formats, wanted_size, offered_text, label);
    if (!chosen.ok()) return Status::Error(chosen.error());
    fourcc = chosen.value();
  }

  stream_config.pixelFormat = libcamera::PixelFormat(fourcc);
  stream_config.size = wanted_size;
  stream_config.bufferCount = options_.buffer_count;
  const std::string requested_text = lc::describeMode(width, height, 0, fourcc);
  if (session.configuration->validate() == libcamera::CameraConfiguration::Invalid) {
    return Status::Error(label + ": cannot capture " + requested_text +
                         ": libcamera rejects the configuration as invalid (the camera offers " +
                         offered_text + ")");
  }
  // validate() may have adjusted the request to what the camera can do.
  const libcamera::Size granted = stream_config.size;
  const uint32_t granted_fourcc = stream_config.pixelFormat.fourcc();
  const std::string granted_text =
      lc::describeMode(granted.width, granted.height, 0, granted_fourcc) +
      (isConvertibleLibcameraFormat(granted_fourcc)
           ? ""
           : " (" + stream_config.pixelFormat.toString() + ")");
  if (granted_fourcc != fourcc) {
    return Status::Error(label + ": cannot capture " + requested_text + "; the camera granted " +
                         granted_text + " (it offers " + offered_text + ")");
  }
  if (!first_open && granted != wanted_size) {
    return Status::Error(label + ": came back granting " + granted_text + " instead of " +
                         requested_text);
  }
  if (const int ret = camera.configure(session.configuration.get()); ret < 0) {
    return Status::Error(label + ": configuring " + granted_text + ": " + lc::errorText(ret));
  }
  session.stream = stream_config.stream();
  session.stride = stream_config.stride;

  // Controls applied when the camera starts.
  const libcamera::ControlInfoMap& available = camera.controls();
  libcamera::ControlList controls(available);
  std::vector<std::string> notes;
  const Expected<double> frame_rate =
      lc::setFrameRate(available, config_, label,
                       lc::describeMode(granted.width, granted.height, 0, fourcc), controls, notes);
  if (!frame_rate.ok()) return Status::Error(frame_rate.error());
  const double fps = frame_rate.value();
  if (Status status = lc::setExposure(available, config_, label, controls, notes); !status.ok()) {
    return status;
  }
  if (Status status = lc::setGain(available, config_, label, controls, notes); !status.ok()) {
    return status;
  }
  session.start_controls = std::move(controls);

  if (!first_open) return Status::Ok();
  fourcc_ = fourcc;
  info_ = {"libcamera", camera_id_, lc::cameraModel(camera),
           {{static_cast<int>(granted.width), static_cast<int>(granted.height), fps,
             libcameraFormatName(fourcc)}}};
  if (granted != wanted_size) {
    notes.insert(notes.begin(),
                 "requested " + lc::describeMode(width, height, config_.fps, fourcc) +
                     ", granted " + lc::describeMode(granted.width, granted.height, fps, fourcc));
  }
  for (const std::string& note : notes) {
    configuration_note_ += (configuration_note_.empty() ? label + ": " : "; ") + note;
  }
  return Status::Ok();
}

Status LibcameraCamera::startStream(LibcameraSession& session) {
  libcamera::Camera& camera = *session.camera;
  const std::string label = "libcamera: camera " + camera_id_;
  session.allocator = std::make_unique<libcamera::FrameBufferAllocator>(session.camera);
  if (const int ret = session.allocator->allocate(session.stream); ret < 0) {
    return Status::Error(label + ": allocating buffers: " + lc::errorText(ret));
  }
  for (const std::unique_ptr<libcamera::FrameBuffer>& buffer : session.allocator->buffers(session.stream)) {
    if (Status status = mapBuffer(session, *buffer); !status.ok()) {
      return Status::Error(label + ": mapping a buffer: " + status.message());
    }
    std::unique_ptr<libcamera::Request> request = camera.createRequest();
    if (!request) return Status::Error(label + ": creating a request failed");
    if (const int ret = request->addBuffer(session.stream, buffer.get()); ret < 0) {
      return Status::Error(label + ": adding a buffer to a request: " + lc::errorText(ret));
    }
    session.requests.push_back(std::move(request));
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    completed_.clear();
    disconnected_ = false;
  }
  camera.requestCompleted.connect(this, &LibcameraCamera::onRequestCompleted);
  camera.disconnected.connect(this, &LibcameraCamera::onDisconnected);
  session.connected = true;
  if (const int ret = camera.start(&session.start_controls); ret < 0) {
    return Status::Error(label + ": start: " + lc::errorText(ret));
  }
  session.started = true;
  for (const std::unique_ptr<libcamera::Request>& request : session.requests) {
    if (const int ret = camera.queueRequest(request.get()); ret < 0) {
      return Status::Error(label + ": queueing a request: " + lc::errorText(ret));
    }
  }
  return Status::Ok();
}

void LibcameraCamera::closeSession() {
  std::unique_ptr<LibcameraSession> session = std::move(session_);
  if (!session) return;
  libcamera::Camera& camera = *session->camera;
  if (session->started) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closing_ = true;
    }
    // Cancels the requests in flight; their completions arrive before stop() returns. A
    // disconnected camera answers with an error, which changes nothing here.
    camera.stop();
  }
  if (session->connected) {
    camera.requestCompleted.disconnect(this);
    camera.disconnected.disconnect(this);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    completed_.clear();
    closing_ = false;
  }
  session->requests.clear();
  session->unmapAll();
  session->allocator.reset();
  if (session->acquired) camera.release();
}

Status LibcameraCamera::start(FrameSink frames, DriverEventSink events) {
  if (thread_.joinable()) return Status::Error("libcamera: camera " + info_.id + ": already started");
  if (!session_) {
    if (Status status = openSession(); !status.ok()) return status;
  }
  if (Status status = startStream(*session_); !status.ok()) {
    closeSession();
    return status;
  }
  frames_ = std::move(frames);
  events_ = std::move(events);
  last_sensor_sequence_.reset();
  stopping_ = false;
  thread_ = std::thread([this] {
    nameThisThread("mocapd-camera");
    workerLoop();
  });
  return Status::Ok();
}

void LibcameraCamera::stop() {
  {
    // Under the lock so a wait cannot miss the wake-up.
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

LibcameraCameraStats LibcameraCamera::stats() const {
  return {delivered_.load(), dropped_.load(), corrupt_.load(),
          failed_.load(),    cancelled_.load(), reopens_.load()};
}

void LibcameraCamera::report(const std::string& message) {
  if (events_) events_(config_.index, message);
}

void LibcameraCamera::onRequestCompleted(libcamera::Request* request) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (request->status() == libcamera::Request::RequestCancelled) {
    if (!closing_) ++cancelled_;
    return;
  }
  completed_.push_back(request);
  wake_.notify_one();
}

void LibcameraCamera::onDisconnected() {
  std::lock_guard<std::mutex> lock(mutex_);
  disconnected_ = true;
  wake_.notify_one();
}

void LibcameraCamera::workerLoop() {
  if (!configuration_note_.empty()) report(configuration_note_);
  while (!stopping_) {
    if (!session_ && !reopenWithBackoff()) break;
    libcamera::Request* request = nullptr;
    bool lost = false;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, options_.wait_timeout,
                     [this] { return stopping_ || disconnected_ || !completed_.empty(); });
      lost = disconnected_;
      if (!lost && !completed_.empty()) {
        request = completed_.front();
        completed_.pop_front();
      }
    }
    if (lost) {
      loseCamera("disconnected");
    } else if (request) {
      processRequest(*request);
    }
  }
  // The camera is stopped and released on the thread that owned it while streaming.
  closeSession();
}

void LibcameraCamera::processRequest(libcamera::Request& request) {
  LibcameraSession& session = *session_;
  const libcamera::FrameBuffer* buffer = request.findBuffer(session.stream);
  const libcamera::FrameMetadata& metadata = buffer->metadata();

  // Sensor sequence numbers count every frame the camera produced, so a gap is frames lost before
  // reaching us (no request queued in time).
  const uint32_t gap =
      last_sensor_sequence_ ? libcameraFramesLost(*last_sensor_sequence_, metadata.sequence) : 0;
  last_sensor_sequence_ = metadata.sequence;
  const uint64_t sequence = next_sequence_ + gap;
  next_sequence_ = sequence + 1;
  dropped_ += gap;
  lost_since_delivery_ += gap;

  // SensorTimestamp is CLOCK_MONOTONIC ns at the start of exposure of the frame's first line. A
  // pipeline that does not report it leaves the buffer's timestamp, the kernel's CLOCK_MONOTONIC
  // time of the frame (start or end of frame, as the V4L2 device defines it).
  const std::optional<int64_t> sensor_ns = request.metadata().get(libcamera::controls::SensorTimestamp);
  const int64_t timestamp_ns = sensor_ns ? *sensor_ns : static_cast<int64_t>(metadata.timestamp);
  const bool corrupt = metadata.status == libcamera::FrameMetadata::FrameError;

  cv::Mat image;
  const auto mapped = session.planes.find(buffer);
  if (metadata.status != libcamera::FrameMetadata::FrameCancelled && mapped != session.planes.end()) {
    const VideoMode& mode = info_.modes.front();
    LibcameraImageView view{fourcc_, mode.width, mode.height, session.stride, {}};
    const libcamera::Span<const libcamera::FrameMetadata::Plane> used = metadata.planes();
    for (size_t i = 0; i < mapped->second.size(); ++i) {
      const std::span<const uint8_t> plane = mapped->second[i];
      // Only the bytes the device wrote: a short frame then fails conversion instead of showing
      // stale pixels, and a JPEG ends where it ends.
      const size_t bytes = i < used.size() && used[i].bytesused > 0
                               ? std::min<size_t>(used[i].bytesused, plane.size())
                               : plane.size();
      view.planes.push_back(plane.first(bytes));
    }
    image = convertLibcameraImage(view, options_.output);
  }

  // Back to the camera before the sink runs: the frame owns a copy.
  request.reuse(libcamera::Request::ReuseBuffers);
  if (const int ret = session.camera->queueRequest(&request); ret < 0) {
    loseCamera("re-queuing a request: " + lc::errorText(ret));
  }

  if (image.empty()) {
    ++failed_;
    ++lost_since_delivery_;
    return;
  }
  Frame frame;
  frame.camera = config_.index;
  frame.sequence = sequence;
  frame.timestamp_ns = timestamp_ns;
  frame.dropped_before = lost_since_delivery_;
  frame.corrupt = corrupt;
  frame.image = std::move(image);
  lost_since_delivery_ = 0;
  if (corrupt) ++corrupt_;
  ++delivered_;
  if (frames_) frames_(std::move(frame));
}

void LibcameraCamera::loseCamera(const std::string& reason) {
  report("camera lost: " + camera_id_ + ": " + reason + "; reopening");
  closeSession();
}

bool LibcameraCamera::reopenWithBackoff() {
  std::chrono::milliseconds delay = options_.reopen_backoff_initial;
  std::string last_failure;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (wake_.wait_for(lock, delay, [this] { return stopping_.load(); })) return false;
    }
    Status status = openSession();
    if (status.ok()) status = startStream(*session_);
    if (status.ok()) {
      ++reopens_;
      // The sensor's sequence restarts; ours continues.
      last_sensor_sequence_.reset();
      report("camera reopened: " + camera_id_);
      return true;
    }
    closeSession();
    // One event per distinct failure: a camera unplugged for an hour must not flood the log.
    if (status.message() != last_failure) {
      last_failure = status.message();
      report("camera still unavailable: " + last_failure);
    }
    delay = std::min(delay * 2, options_.reopen_backoff_max);
  }
}

}  // namespace mocap
