// Registers every camera driver compiled into this build (a driver whose library was missing at
// build time is simply absent).
#pragma once

#include "drivers/camera_driver.h"

namespace mocap {

void registerBuiltinDrivers(DriverRegistry& registry);

}  // namespace mocap
