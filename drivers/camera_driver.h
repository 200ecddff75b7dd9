// The camera driver interface: a small pure-virtual backend, one implementation per folder
// (v4l2/, aravis/, libcamera/, fake/), registered by name in the DriverRegistry.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drivers/frame.h"
#include "drivers/status.h"

namespace mocap {

struct VideoMode {
  int width = 0;
  int height = 0;
  double fps = 0;            // 0 when the device does not say
  std::string pixel_format;  // FourCC or GenICam name, e.g. "YUYV", "GREY", "MJPG", "Mono8"
};

struct CameraInfo {
  std::string driver;  // registry name of the driver that sees it
  std::string id;      // stable id to put in a config (path, serial, ...)
  std::string model;   // human-readable model / card name
  std::vector<VideoMode> modes;
};

enum class TriggerMode { kFreeRun, kSoftware, kHardwareLine };

// Typed configuration of one camera, as it appears in the daemon's YAML config.
struct CameraConfig {
  int index = 0;             // position in the rig; copied into Frame::camera
  std::string driver;        // "v4l2", "aravis", "libcamera", "fake"
  std::string device;        // path, serial, name or index, as the driver understands it
  int width = 780;
  int height = 580;
  double fps = 25.0;
  std::string pixel_format;  // empty: the driver picks the best it supports
  std::optional<double> exposure_us;
  std::optional<double> gain_db;
  TriggerMode trigger = TriggerMode::kFreeRun;
  std::string trigger_line;  // for kHardwareLine, e.g. "Line1"
};

// Something the driver wants the operator to know (camera lost, reopened, ...). Called on a
// driver thread.
using DriverEventSink = std::function<void(int camera, const std::string& message)>;

// An opened camera. Frames are delivered on the driver's own thread(s) between start() and stop().
// A camera that vanishes mid-stream is reported through the event sink and reopened with backoff;
// stop() always returns promptly.
class Camera {
 public:
  virtual ~Camera() = default;
  virtual const CameraInfo& info() const = 0;
  virtual Status start(FrameSink frames, DriverEventSink events) = 0;
  virtual void stop() = 0;
  // Fires one exposure in TriggerMode::kSoftware; an error otherwise.
  virtual Status trigger() { return Status::Error("software trigger not supported by this camera"); }
};

class Driver {
 public:
  virtual ~Driver() = default;
  virtual std::string name() const = 0;
  virtual std::vector<CameraInfo> enumerate() = 0;
  virtual Expected<std::unique_ptr<Camera>> open(const CameraConfig& config) = 0;
};

// Drivers compiled into this build, by name.
class DriverRegistry {
 public:
  using Factory = std::function<std::unique_ptr<Driver>()>;
  static DriverRegistry& instance();
  void add(const std::string& name, Factory factory);
  std::vector<std::string> names() const;
  std::unique_ptr<Driver> create(const std::string& name) const;  // nullptr if unknown

 private:
  std::vector<std::pair<std::string, Factory>> factories_;
};

}  // namespace mocap
