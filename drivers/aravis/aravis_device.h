// Finding and opening Aravis devices by the name a config gives, and describing them for
// enumeration. Internal to drivers/aravis/ (it pulls in <arv.h>).
#pragma once

#include <string>
#include <vector>

#include "drivers/aravis/aravis_glib.h"
#include "drivers/camera_driver.h"
#include "drivers/status.h"

namespace mocap::aravis {

struct OpenedCamera {
  GObjectPtr<ArvCamera> camera;
  std::string device_id;  // what to pass here again to reopen the same device
};

// `device` is an IPv4 address (a GigE Vision camera opened directly by unicast, without a
// discovery broadcast: also reaches cameras on other subnets), an Aravis device id as enumerate()
// lists it, a serial number, anything else Aravis itself resolves (GigE Vision user-defined name,
// MAC address, host name), or empty for the first camera found.
Expected<OpenedCamera> openCamera(const std::string& device);

// Every device the enabled Aravis interfaces see, with the modes it reports when it can be opened
// (a camera controlled by another application is listed without modes).
std::vector<CameraInfo> listCameras(const std::string& driver_name);

// What the camera reports: for each convertible pixel format it offers, its largest region at the
// highest frame rate it allows with its current settings (0 when it does not say).
std::vector<VideoMode> cameraModes(ArvCamera* camera);

}  // namespace mocap::aravis
