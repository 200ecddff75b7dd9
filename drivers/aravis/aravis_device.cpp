// Device lookup and enumeration through Aravis' global device list.
#include "drivers/aravis/aravis_device.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "drivers/aravis/aravis_convert.h"

namespace mocap::aravis {
namespace {

constexpr uint16_t kGvcpPort = 3956;

struct DeviceEntry {
  std::string id;
  std::string serial;
  std::string vendor;
  std::string model;
};

// Caller holds systemMutex().
std::vector<DeviceEntry> updateDeviceList() {
  arv_update_device_list();
  std::vector<DeviceEntry> devices;
  for (unsigned int i = 0; i < arv_get_n_devices(); ++i) {
    devices.push_back({orEmpty(arv_get_device_id(i)), orEmpty(arv_get_device_serial_nbr(i)),
                       orEmpty(arv_get_device_vendor(i)), orEmpty(arv_get_device_model(i))});
  }
  return devices;
}

std::string describeDevices(const std::vector<DeviceEntry>& devices) {
  std::string text;
  for (const DeviceEntry& device : devices) {
    text += (text.empty() ? "" : ", ") + device.id + " (" + device.vendor + " " + device.model + ")";
  }
  return text.empty() ? "none" : text;
}

// The local address the kernel routes to `device` from: connecting a UDP socket sends nothing.
Expected<std::string> localAddressFor(const std::string& device) {
  sockaddr_in remote{};
  remote.sin_family = AF_INET;
  remote.sin_port = htons(kGvcpPort);
  if (inet_pton(AF_INET, device.c_str(), &remote.sin_addr) != 1) {
    return Status::Error("aravis: '" + device + "' is not an IPv4 address");
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return Status::Error(std::string("aravis: socket: ") + std::strerror(errno));
  sockaddr_in local{};
  socklen_t length = sizeof local;
  const bool routed = ::connect(fd, reinterpret_cast<sockaddr*>(&remote), sizeof remote) == 0 &&
                      ::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &length) == 0;
  const int error = errno;
  ::close(fd);
  if (!routed) {
    return Status::Error("aravis: no route to " + device + ": " + std::strerror(error));
  }
  char text[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &local.sin_addr, text, sizeof text);
  return std::string(text);
}

Expected<OpenedCamera> openByAddress(const std::string& address) {
  Expected<std::string> local = localAddressFor(address);
  if (!local.ok()) return Status::Error(local.error());
  GObjectPtr<GInetAddress> device_address(g_inet_address_new_from_string(address.c_str()));
  GObjectPtr<GInetAddress> interface_address(g_inet_address_new_from_string(local.value().c_str()));
  GErrorHolder error;
  GObjectPtr<ArvDevice> device(
      arv_gv_device_new(interface_address.get(), device_address.get(), error.out()));
  if (!device) {
    return Status::Error("aravis: no GigE Vision camera answers at " + address + ": " +
                         (error ? error.message() : "no reply"));
  }
  GObjectPtr<ArvCamera> camera(arv_camera_new_with_device(device.get(), error.out()));
  if (!camera) return Status::Error("aravis: camera at " + address + ": " + error.message());
  return OpenedCamera{std::move(camera), address};
}

bool isIpv4Address(const std::string& text) {
  in_addr ignored{};
  return inet_pton(AF_INET, text.c_str(), &ignored) == 1;
}

}  // namespace

std::mutex& systemMutex() {
  static std::mutex mutex;
  return mutex;
}

Expected<OpenedCamera> openCamera(const std::string& device) {
  if (isIpv4Address(device)) return openByAddress(device);
  std::lock_guard<std::mutex> lock(systemMutex());
  const std::vector<DeviceEntry> devices = updateDeviceList();
  std::string id;
  for (const DeviceEntry& entry : devices) {
    if (device.empty() || entry.id == device || entry.serial == device) {
      id = entry.id;
      break;
    }
  }
  if (device.empty() && id.empty()) return Status::Error("aravis: no camera found");
  if (id.empty()) id = device;  // Aravis' own aliases: user-defined name, MAC, host name.
  GErrorHolder error;
  GObjectPtr<ArvCamera> camera(arv_camera_new(id.c_str(), error.out()));
  if (!camera) {
    return Status::Error("aravis: cannot open camera '" + id + "': " +
                         (error ? error.message() : "not found") +
                         "; found: " + describeDevices(devices));
  }
  return OpenedCamera{std::move(camera), id};
}

std::vector<VideoMode> cameraModes(ArvCamera* camera) {
  GErrorHolder error;
  guint count = 0;
  std::unique_ptr<gint64, GFree> formats(
      arv_camera_dup_available_pixel_formats(camera, &count, error.out()));
  if (!formats) return {};
  gint width_min = 0, width_max = 0, height_min = 0, height_max = 0;
  arv_camera_get_width_bounds(camera, &width_min, &width_max, error.out());
  if (error) return {};
  arv_camera_get_height_bounds(camera, &height_min, &height_max, error.out());
  if (error) return {};
  double fps_min = 0, fps_max = 0;
  if (arv_camera_is_frame_rate_available(camera, nullptr)) {
    arv_camera_get_frame_rate_bounds(camera, &fps_min, &fps_max, error.out());
    if (error) fps_max = 0;
  }
  std::vector<VideoMode> modes;
  for (guint i = 0; i < count; ++i) {
    const auto format = static_cast<uint32_t>(formats.get()[i]);
    if (!isConvertibleArvPixelFormat(format)) continue;
    modes.push_back({width_max, height_max, fps_max, arvPixelFormatName(format)});
  }
  return modes;
}

std::vector<CameraInfo> listCameras(const std::string& driver_name) {
  std::lock_guard<std::mutex> lock(systemMutex());
  std::vector<CameraInfo> cameras;
  for (const DeviceEntry& entry : updateDeviceList()) {
    CameraInfo info{driver_name, entry.id, entry.vendor + " " + entry.model, {}};
    GErrorHolder error;
    GObjectPtr<ArvCamera> camera(arv_camera_new(entry.id.c_str(), error.out()));
    if (camera) info.modes = cameraModes(camera.get());
    cameras.push_back(std::move(info));
  }
  return cameras;
}

}  // namespace mocap::aravis
