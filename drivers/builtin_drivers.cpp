// One line per driver folder; each is guarded by the definition its CMake target exports.
#include "drivers/builtin_drivers.h"

#ifdef MOCAP_HAVE_ARAVIS
#include "drivers/aravis/aravis_driver.h"
#endif
#include "drivers/fake/fake_driver.h"
#ifdef MOCAP_HAVE_LIBCAMERA
#include "drivers/libcamera/libcamera_driver.h"
#endif
#include "drivers/v4l2/v4l2_driver.h"

namespace mocap {

void registerBuiltinDrivers(DriverRegistry& registry) {
  registerV4l2Driver(registry);
  registerFakeDriver(registry);
#ifdef MOCAP_HAVE_ARAVIS
  registerAravisDriver(registry);
#endif
#ifdef MOCAP_HAVE_LIBCAMERA
  registerLibcameraDriver(registry);
#endif
}

}  // namespace mocap
