// The Aravis Camera: configuration, the capture thread, frame bookkeeping and reopen-with-backoff.
//
// Buffers are taken by a dedicated capture thread with arv_stream_timeout_pop_buffer rather than
// in the stream callback: the callback runs on Aravis' packet-receiving thread, where converting
// a frame and calling the sink would delay reception of the next frame's packets; the capture
// thread also has to tear the stream down and reopen the camera after a loss, which cannot be done
// from inside that stream's own callback; and the pop timeout bounds how long stop() waits.
#include "drivers/aravis/aravis_camera.h"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "drivers/aravis/aravis_convert.h"
#include "drivers/aravis/aravis_device.h"
#include "drivers/aravis/aravis_glib.h"
#include "drivers/thread_name.h"

namespace mocap {

struct AravisSession {
  aravis::GObjectPtr<ArvCamera> camera;
  aravis::GObjectPtr<ArvStream> stream;
  gulong control_lost_handler = 0;
  // Set on Aravis' heartbeat thread when the GigE Vision device stops answering.
  std::atomic<bool> control_lost{false};
  bool acquiring = false;
};

namespace {

using aravis::GErrorHolder;
using aravis::GObjectPtr;

void onControlLost(ArvDevice*, gpointer session) {
  static_cast<AravisSession*>(session)->control_lost = true;
}

int64_t clockNs(clockid_t clock) {
  timespec now{};
  clock_gettime(clock, &now);
  return static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

// Where in [min, max] in steps of `increment` from min `value` lies, or why it does not.
std::string checkRange(const char* what, int value, int min, int max, int increment) {
  const int step = std::max(increment, 1);
  if (value >= min && value <= max && (value - min) % step == 0) return "";
  return std::string(what) + " " + std::to_string(value) + " is not possible: " +
         std::to_string(min) + ".." + std::to_string(max) +
         (step > 1 ? " in steps of " + std::to_string(step) : "");
}

bool isLoopbackGvCamera(ArvCamera* camera) {
  if (!arv_camera_is_gv_device(camera)) return false;
  GSocketAddress* address =
      arv_gv_device_get_device_address(ARV_GV_DEVICE(arv_camera_get_device(camera)));
  return address && G_IS_INET_SOCKET_ADDRESS(address) &&
         g_inet_address_get_is_loopback(
             g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(address)));
}

Status failure(const std::string& label, const std::string& what, const GErrorHolder& error) {
  return Status::Error(label + ": " + what + ": " + error.message());
}

// The config's pixel format, else the camera's current one when convertible, else ours in order.
// `fixed` is the first open's choice, which every reopen keeps.
Expected<uint32_t> choosePixelFormat(ArvCamera* camera, const CameraConfig& config, uint32_t fixed,
                                     const std::string& label) {
  GErrorHolder error;
  guint count = 0;
  std::unique_ptr<gint64, aravis::GFree> codes(
      arv_camera_dup_available_pixel_formats(camera, &count, error.out()));
  if (error) return failure(label, "reading PixelFormat", error);
  aravis::BorrowedStrings names(
      arv_camera_dup_available_pixel_formats_as_strings(camera, &count, error.out()));
  if (error) return failure(label, "reading PixelFormat", error);
  if (fixed != 0) return fixed;
  std::string offered;
  for (guint i = 0; i < count; ++i) offered += (i ? ", " : "") + aravis::orEmpty(names[i]);
  auto isOffered = [&](uint32_t code) {
    return std::any_of(codes.get(), codes.get() + count,
                       [&](gint64 offered_code) { return offered_code == code; });
  };
  uint32_t format = 0;
  if (!config.pixel_format.empty()) {
    for (guint i = 0; i < count; ++i) {
      if (config.pixel_format == aravis::orEmpty(names[i]))
        format = static_cast<uint32_t>(codes.get()[i]);
    }
    if (format == 0) {
      return Status::Error(label + ": pixel format '" + config.pixel_format +
                           "' not offered; the camera offers " + offered);
    }
    if (!isConvertibleArvPixelFormat(format)) {
      return Status::Error(label + ": pixel format '" + config.pixel_format +
                           "' is not supported by mocapd; use one of " +
                           convertibleArvPixelFormatList());
    }
    return format;
  }
  const auto current = static_cast<uint32_t>(arv_camera_get_pixel_format(camera, error.out()));
  if (!error && isConvertibleArvPixelFormat(current) && isOffered(current)) format = current;
  for (uint32_t candidate : convertibleArvPixelFormats()) {
    if (format == 0 && isOffered(candidate)) format = candidate;
  }
  if (format == 0) {
    return Status::Error(label + ": offers only " + offered + "; mocapd converts " +
                         convertibleArvPixelFormatList());
  }
  return format;
}

// The configured size at the sensor's top-left corner: offsets first, so the width and height
// bounds are the sensor's own. Succeeds only when the camera keeps exactly that size.
Status setRegion(ArvCamera* camera, const CameraConfig& config, const std::string& label) {
  GErrorHolder error;
  gint x = 0, y = 0, width = 0, height = 0;
  arv_camera_get_region(camera, &x, &y, &width, &height, error.out());
  if (error) return failure(label, "reading the region", error);
  if ((x != 0 || y != 0) && arv_camera_is_region_offset_available(camera, nullptr)) {
    arv_camera_set_region(camera, 0, 0, width, height, error.out());
    if (error) return failure(label, "resetting the region offset", error);
  }
  gint min = 0, max = 0;
  arv_camera_get_width_bounds(camera, &min, &max, error.out());
  if (error) return failure(label, "reading Width bounds", error);
  std::string range =
      checkRange("width", config.width, min, max, arv_camera_get_width_increment(camera, nullptr));
  arv_camera_get_height_bounds(camera, &min, &max, error.out());
  if (error) return failure(label, "reading Height bounds", error);
  if (range.empty()) {
    range = checkRange("height", config.height, min, max,
                       arv_camera_get_height_increment(camera, nullptr));
  }
  if (!range.empty()) return Status::Error(label + ": " + range);
  arv_camera_set_region(camera, 0, 0, config.width, config.height, error.out());
  if (error) return failure(label, "setting the region", error);
  arv_camera_get_region(camera, &x, &y, &width, &height, error.out());
  if (error) return failure(label, "reading the region", error);
  if (width != config.width || height != config.height) {
    return Status::Error(label + ": requested " + std::to_string(config.width) + "x" +
                         std::to_string(config.height) + ", the camera kept " +
                         std::to_string(width) + "x" + std::to_string(height));
  }
  return Status::Ok();
}

// Free-run only: a triggered camera runs at its trigger's rate. Returns the rate granted (the
// configured one when the camera cannot tell).
Expected<double> setFrameRate(ArvCamera* camera, const CameraConfig& config,
                              const std::string& label, std::vector<std::string>& notes) {
  if (config.trigger != TriggerMode::kFreeRun) return config.fps;
  if (!arv_camera_is_frame_rate_available(camera, nullptr)) {
    notes.push_back("frame rate not settable; the camera runs at its own rate");
    return config.fps;
  }
  GErrorHolder error;
  double fps_min = 0, fps_max = 0;
  arv_camera_get_frame_rate_bounds(camera, &fps_min, &fps_max, error.out());
  if (error) return failure(label, "reading AcquisitionFrameRate bounds", error);
  if (config.fps < fps_min || config.fps > fps_max) {
    return Status::Error(label + ": " + number(config.fps) + " fps is not possible at " +
                         std::to_string(config.width) + "x" + std::to_string(config.height) + ": " +
                         number(fps_min) + ".." + number(fps_max));
  }
  arv_camera_set_frame_rate(camera, config.fps, error.out());
  if (error) return failure(label, "setting AcquisitionFrameRate", error);
  const double fps = arv_camera_get_frame_rate(camera, error.out());
  if (error) return failure(label, "reading AcquisitionFrameRate", error);
  if (std::abs(fps - config.fps) > 0.01 * config.fps) {
    notes.push_back("requested " + number(config.fps) + " fps, granted " + number(fps));
  }
  return fps;
}

Status setExposure(ArvCamera* camera, const CameraConfig& config, const std::string& label,
                   std::vector<std::string>& notes) {
  if (!config.exposure_us) return Status::Ok();
  if (!arv_camera_is_exposure_time_available(camera, nullptr)) {
    notes.push_back("exposure_us not applied: the camera has no exposure time control");
    return Status::Ok();
  }
  GErrorHolder error;
  double exposure_min = 0, exposure_max = 0;
  arv_camera_get_exposure_time_bounds(camera, &exposure_min, &exposure_max, error.out());
  if (error) return failure(label, "reading ExposureTime bounds", error);
  if (*config.exposure_us < exposure_min || *config.exposure_us > exposure_max) {
    return Status::Error(label + ": exposure_us " + number(*config.exposure_us) +
                         " is not possible: " + number(exposure_min) + ".." + number(exposure_max));
  }
  if (arv_camera_is_exposure_auto_available(camera, nullptr)) {
    arv_camera_set_exposure_time_auto(camera, ARV_AUTO_OFF, error.out());
    if (error) return failure(label, "setting ExposureAuto Off", error);
  }
  arv_camera_set_exposure_time(camera, *config.exposure_us, error.out());
  if (error) return failure(label, "setting ExposureTime", error);
  return Status::Ok();
}

Status setGain(ArvCamera* camera, const CameraConfig& config, const std::string& label,
               std::vector<std::string>& notes) {
  if (!config.gain_db) return Status::Ok();
  // GainRaw is in device units; only the standard Gain feature is in dB.
  if (!arv_camera_is_feature_available(camera, "Gain", nullptr)) {
    notes.push_back("gain_db not applied: the camera has no Gain feature in dB");
    return Status::Ok();
  }
  GErrorHolder error;
  double gain_min = 0, gain_max = 0;
  arv_camera_get_gain_bounds(camera, &gain_min, &gain_max, error.out());
  if (error) return failure(label, "reading Gain bounds", error);
  if (*config.gain_db < gain_min || *config.gain_db > gain_max) {
    return Status::Error(label + ": gain_db " + number(*config.gain_db) +
                         " is not possible: " + number(gain_min) + ".." + number(gain_max));
  }
  if (arv_camera_is_gain_auto_available(camera, nullptr)) {
    arv_camera_set_gain_auto(camera, ARV_AUTO_OFF, error.out());
    if (error) return failure(label, "setting GainAuto Off", error);
  }
  arv_camera_set_gain(camera, *config.gain_db, error.out());
  if (error) return failure(label, "setting Gain", error);
  return Status::Ok();
}

Status setTrigger(ArvCamera* camera, const CameraConfig& config, const std::string& label) {
  GErrorHolder error;
  switch (config.trigger) {
    case TriggerMode::kFreeRun:
      if (arv_camera_is_feature_available(camera, "TriggerMode", nullptr)) {
        arv_camera_clear_triggers(camera, error.out());
        if (error) return failure(label, "switching triggers off", error);
      }
      break;
    case TriggerMode::kSoftware:
      if (!arv_camera_is_software_trigger_supported(camera, nullptr)) {
        return Status::Error(label + ": has no software trigger");
      }
      arv_camera_set_trigger(camera, "Software", error.out());
      if (error) return failure(label, "setting the software trigger", error);
      break;
    case TriggerMode::kHardwareLine: {
      guint n_sources = 0;
      aravis::BorrowedStrings sources(
          arv_camera_dup_available_trigger_sources(camera, &n_sources, error.out()));
      if (error) return failure(label, "reading TriggerSource", error);
      std::string listed;
      bool found = false;
      for (guint i = 0; i < n_sources; ++i) {
        listed += (i ? ", " : "") + aravis::orEmpty(sources[i]);
        found = found || config.trigger_line == aravis::orEmpty(sources[i]);
      }
      if (!found) {
        return Status::Error(label + ": no trigger source '" + config.trigger_line +
                             "'; the camera offers " + (listed.empty() ? "none" : listed));
      }
      arv_camera_set_trigger(camera, config.trigger_line.c_str(), error.out());
      if (error) return failure(label, "setting the trigger on " + config.trigger_line, error);
      break;
    }
  }
  return Status::Ok();
}

}  // namespace

AravisCamera::AravisCamera(const CameraConfig& config, const AravisOptions& options)
    : config_(config), options_(options) {}

Expected<std::unique_ptr<AravisCamera>> AravisCamera::open(const CameraConfig& config,
                                                           const AravisOptions& options) {
  if (config.trigger == TriggerMode::kHardwareLine && config.trigger_line.empty()) {
    return Status::Error("aravis: camera '" + config.device +
                         "': hardware trigger needs trigger_line (e.g. Line1)");
  }
  std::unique_ptr<AravisCamera> camera(new AravisCamera(config, options));
  if (Status status = camera->openSession(); !status.ok()) return status;
  return camera;
}

AravisCamera::~AravisCamera() {
  stop();
  closeSession();
}

Status AravisCamera::openSession() {
  const bool first_open = device_id_.empty();
  Expected<aravis::OpenedCamera> opened =
      aravis::openCamera(first_open ? config_.device : device_id_);
  if (!opened.ok()) return Status::Error(opened.error());
  auto session = std::make_unique<AravisSession>();
  session->camera = std::move(opened.value().camera);
  if (first_open) device_id_ = opened.value().device_id;
  if (Status status = configure(*session); !status.ok()) {
    if (first_open) device_id_.clear();
    return status;
  }
  session->control_lost_handler =
      g_signal_connect(arv_camera_get_device(session->camera.get()), "control-lost",
                       G_CALLBACK(onControlLost), session.get());
  std::lock_guard<std::mutex> lock(session_mutex_);
  session_ = std::move(session);
  return Status::Ok();
}

Status AravisCamera::configure(AravisSession& session) {
  ArvCamera* camera = session.camera.get();
  const bool first_open = pixel_format_ == 0;
  const std::string label = "aravis: camera " + device_id_;
  const Expected<uint32_t> format = choosePixelFormat(camera, config_, pixel_format_, label);
  if (!format.ok()) return Status::Error(format.error());
  GErrorHolder error;
  arv_camera_set_pixel_format(camera, format.value(), error.out());
  if (error)
    return failure(label, "setting PixelFormat " + arvPixelFormatName(format.value()), error);
  if (Status status = setRegion(camera, config_, label); !status.ok()) return status;
  std::vector<std::string> notes;
  const Expected<double> fps = setFrameRate(camera, config_, label, notes);
  if (!fps.ok()) return Status::Error(fps.error());
  if (Status status = setExposure(camera, config_, label, notes); !status.ok()) return status;
  if (Status status = setGain(camera, config_, label, notes); !status.ok()) return status;
  if (Status status = setTrigger(camera, config_, label); !status.ok()) return status;

  if (!first_open) return Status::Ok();
  pixel_format_ = format.value();
  const std::string vendor = aravis::orEmpty(arv_camera_get_vendor_name(camera, nullptr));
  const std::string model = aravis::orEmpty(arv_camera_get_model_name(camera, nullptr));
  info_ = {"aravis",
           device_id_,
           vendor + (vendor.empty() ? "" : " ") + model,
           {{config_.width, config_.height, fps.value(), arvPixelFormatName(format.value())}}};
  for (const std::string& note : notes) {
    configuration_note_ += (configuration_note_.empty() ? label + ": " : "; ") + note;
  }
  return Status::Ok();
}

Status AravisCamera::startStream(AravisSession& session) {
  ArvCamera* camera = session.camera.get();
  const std::string label = "aravis: camera " + device_id_;
  GErrorHolder error;
  if (arv_camera_is_gv_device(camera)) {
    const bool packet_socket = options_.gv_packet_socket && !isLoopbackGvCamera(camera);
    arv_camera_gv_set_stream_options(camera, packet_socket
                                                 ? ARV_GV_STREAM_OPTION_NONE
                                                 : ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
  }
  session.stream.reset(arv_camera_create_stream(camera, nullptr, nullptr, error.out()));
  if (!session.stream) return Status::Error(label + ": creating the stream: " + error.message());
  if (ARV_IS_GV_STREAM(session.stream.get())) {
    // Sized to the payload, so a whole frame fits in the socket while the receiver is busy.
    g_object_set(session.stream.get(), "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_AUTO, nullptr);
  }
  const guint payload = arv_camera_get_payload(camera, error.out());
  if (error) return Status::Error(label + ": reading PayloadSize: " + error.message());
  for (uint32_t i = 0; i < options_.buffer_count; ++i) {
    arv_stream_push_buffer(session.stream.get(), arv_buffer_new_allocate(payload));
  }
  arv_camera_start_acquisition(camera, error.out());
  if (error) return Status::Error(label + ": starting acquisition: " + error.message());
  session.acquiring = true;
  return Status::Ok();
}

void AravisCamera::closeSession() {
  std::unique_ptr<AravisSession> session;
  {
    std::lock_guard<std::mutex> lock(session_mutex_);
    session = std::move(session_);
  }
  if (!session) return;
  ArvCamera* camera = session->camera.get();
  // A camera known to be gone would only make us wait for its timeouts.
  if (session->acquiring && !session->control_lost) arv_camera_stop_acquisition(camera, nullptr);
  session->stream.reset();  // joins the stream's receiving thread
  g_signal_handler_disconnect(arv_camera_get_device(camera), session->control_lost_handler);
}

Status AravisCamera::start(FrameSink frames, DriverEventSink events) {
  if (thread_.joinable()) return Status::Error("aravis: camera " + info_.id + ": already started");
  if (!session_) {
    if (Status status = openSession(); !status.ok()) return status;
  }
  if (Status status = startStream(*session_); !status.ok()) {
    closeSession();
    return status;
  }
  frames_ = std::move(frames);
  events_ = std::move(events);
  last_frame_id_.reset();
  stopping_ = false;
  thread_ = std::thread([this] {
    nameThisThread("mocapd-camera");
    captureLoop();
  });
  return Status::Ok();
}

void AravisCamera::stop() {
  {
    // Under the lock so a backoff wait cannot miss the wake-up.
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stopping_ = true;
  }
  stop_signal_.notify_all();
  if (thread_.joinable()) thread_.join();
}

Status AravisCamera::trigger() {
  if (config_.trigger != TriggerMode::kSoftware) {
    return Status::Error("aravis: camera " + info_.id + " is not configured for software trigger");
  }
  std::lock_guard<std::mutex> lock(session_mutex_);
  if (!session_) return Status::Error("aravis: camera " + info_.id + " is not open (reopening)");
  GErrorHolder error;
  arv_camera_software_trigger(session_->camera.get(), error.out());
  if (error) return Status::Error("aravis: camera " + info_.id + ": TriggerSoftware: " + error.message());
  return Status::Ok();
}

AravisCameraStats AravisCamera::stats() const {
  return {delivered_.load(), dropped_.load(), corrupt_.load(), failed_.load(), reopens_.load()};
}

void AravisCamera::report(const std::string& message) {
  if (events_) events_(config_.index, message);
}

void AravisCamera::captureLoop() {
  if (!configuration_note_.empty()) report(configuration_note_);
  last_activity_ = std::chrono::steady_clock::now();
  while (!stopping_) {
    if (!session_ && !reopenWithBackoff()) break;
    captureOnce();
  }
  // Acquisition stops and the camera is released on the thread that owned it while streaming.
  closeSession();
}

void AravisCamera::captureOnce() {
  AravisSession& session = *session_;
  if (session.control_lost) {
    loseCamera("control lost (the camera stopped answering its heartbeat)");
    return;
  }
  const auto timeout_us = static_cast<guint64>(
      std::chrono::duration_cast<std::chrono::microseconds>(options_.pop_timeout).count());
  ArvBuffer* buffer = arv_stream_timeout_pop_buffer(session.stream.get(), timeout_us);
  if (!buffer) {
    handleStall();
    return;
  }
  const int64_t popped_ns = clockNs(CLOCK_MONOTONIC);
  last_activity_ = std::chrono::steady_clock::now();
  const ArvBufferStatus status = arv_buffer_get_status(buffer);

  // Ids count every frame the camera sent, so a gap is frames lost on the way (no free buffer,
  // dropped packets beyond resend).
  const uint64_t frame_id = arv_buffer_get_frame_id(buffer);
  const uint64_t gap = last_frame_id_ ? framesLostBetween(*last_frame_id_, frame_id) : 0;
  last_frame_id_ = frame_id;
  const uint64_t sequence = next_sequence_ + gap;
  next_sequence_ = sequence + 1;
  dropped_ += gap;
  lost_since_delivery_ += static_cast<uint32_t>(std::min<uint64_t>(gap, UINT32_MAX));

  cv::Mat image;
  const ArvBufferPayloadType payload_type = arv_buffer_get_payload_type(buffer);
  const bool has_image = payload_type == ARV_BUFFER_PAYLOAD_TYPE_IMAGE ||
                         payload_type == ARV_BUFFER_PAYLOAD_TYPE_EXTENDED_CHUNK_DATA;
  if (has_image && status == ARV_BUFFER_STATUS_SUCCESS) {
    size_t size = 0;
    ArvImageView view;
    view.data = static_cast<const uint8_t*>(arv_buffer_get_image_data(buffer, &size));
    view.size = size;
    view.pixel_format = arv_buffer_get_image_pixel_format(buffer);
    view.width = arv_buffer_get_image_width(buffer);
    view.height = arv_buffer_get_image_height(buffer);
    gint x_padding = 0;
    arv_buffer_get_image_padding(buffer, &x_padding, nullptr);
    view.line_padding = static_cast<size_t>(std::max(x_padding, 0));
    image = convertArvImage(view);
  } else if (status == ARV_BUFFER_STATUS_MISSING_PACKETS || status == ARV_BUFFER_STATUS_TIMEOUT) {
    // Holes in an otherwise complete frame: delivered, flagged corrupt. Aravis describes only
    // complete images, so the configured geometry stands in for the buffer's own. Anything else
    // (aborted, size mismatch, cleared) has nothing to show.
    size_t size = 0;
    const VideoMode& mode = info_.modes.front();
    image = convertArvImage({pixel_format_, mode.width, mode.height, 0,
                             static_cast<const uint8_t*>(arv_buffer_get_data(buffer, &size)), size});
  }
  // Aravis' system timestamp is CLOCK_REALTIME at the arrival of the frame's first packet.
  const uint64_t system_ns = arv_buffer_get_system_timestamp(buffer);
  const int64_t arrival_ns =
      system_ns != 0
          ? static_cast<int64_t>(system_ns) - (clockNs(CLOCK_REALTIME) - clockNs(CLOCK_MONOTONIC))
          : popped_ns;
  const uint64_t device_ns = arv_buffer_get_timestamp(buffer);
  // Back to the pool before the sink runs: the frame owns a copy.
  arv_stream_push_buffer(session.stream.get(), buffer);

  if (image.empty()) {
    ++failed_;
    ++lost_since_delivery_;
    return;
  }
  Frame frame;
  frame.camera = config_.index;
  frame.sequence = sequence;
  frame.timestamp_ns = clock_.map(device_ns, arrival_ns);
  frame.dropped_before = lost_since_delivery_;
  frame.corrupt = status != ARV_BUFFER_STATUS_SUCCESS;
  frame.image = std::move(image);
  lost_since_delivery_ = 0;
  if (frame.corrupt) ++corrupt_;
  ++delivered_;
  if (frames_) frames_(std::move(frame));
}

void AravisCamera::handleStall() {
  const auto now = std::chrono::steady_clock::now();
  const auto frame_period = std::chrono::duration<double>(config_.fps > 0 ? 1.0 / config_.fps : 0);
  const auto limit = std::max<std::chrono::steady_clock::duration>(
      options_.stall_timeout,
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(frame_period * 10));
  if (now - last_activity_ < limit) return;
  last_activity_ = now;
  // A register read tells a silent camera (stream lost, or simply not triggered) from a gone one.
  GErrorHolder error;
  arv_camera_get_payload(session_->camera.get(), error.out());
  if (error) {
    session_->control_lost = true;
    loseCamera("the camera does not answer: " + error.message());
  } else if (config_.trigger == TriggerMode::kFreeRun) {
    const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(limit).count();
    loseCamera("no frame for " + std::to_string(waited) + " ms although the camera answers");
  }
}

void AravisCamera::loseCamera(const std::string& reason) {
  report("camera lost: " + device_id_ + ": " + reason + "; reopening");
  closeSession();
}

bool AravisCamera::reopenWithBackoff() {
  std::chrono::milliseconds delay = options_.reopen_backoff_initial;
  std::string last_failure;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(stop_mutex_);
      if (stop_signal_.wait_for(lock, delay, [this] { return stopping_.load(); })) return false;
    }
    Status status = openSession();
    if (status.ok()) status = startStream(*session_);
    if (status.ok()) {
      ++reopens_;
      // The camera's frame ids and clock restart; our sequence and timestamps continue.
      last_frame_id_.reset();
      clock_.reset();
      last_activity_ = std::chrono::steady_clock::now();
      report("camera reopened: " + device_id_);
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
