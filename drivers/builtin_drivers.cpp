// One line per driver folder; each is guarded by the definition its CMake target exports.
#include "drivers/builtin_drivers.h"

#include "drivers/v4l2/v4l2_driver.h"

namespace mocap {

void registerBuiltinDrivers(DriverRegistry& registry) {
  registerV4l2Driver(registry);
}

}  // namespace mocap
