// Tests of the libcamera driver against this machine's real libcamera, which sees no camera
// (libcamera 0.0.3 has no virtual pipeline): registration, enumeration and the "no camera" report,
// clear errors when opening a camera that is not there, and configs refused before any camera is
// looked up. Capture itself needs a camera (see docs/acquisition.md).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "drivers/builtin_drivers.h"
#include "drivers/libcamera/libcamera_camera.h"
#include "drivers/libcamera/libcamera_driver.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;

bool contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

CameraConfig configFor(const std::string& device) {
  CameraConfig config;
  config.driver = "libcamera";
  config.device = device;
  return config;
}

std::string openError(LibcameraDriver& driver, const CameraConfig& config) {
  Expected<std::unique_ptr<Camera>> camera = driver.open(config);
  EXPECT_FALSE(camera.ok());
  return camera.ok() ? std::string() : camera.error();
}

// The tests of a camera-less machine: skipped where libcamera does see a camera.
class NoCamera : public ::testing::Test {
 protected:
  void SetUp() override {
    if (driver_.checkCameras().ok()) GTEST_SKIP() << "libcamera sees a camera on this machine";
  }
  LibcameraDriver driver_;
};

TEST(LibcameraRegistration, RegistersAsLibcamera) {
  DriverRegistry registry;
  registerLibcameraDriver(registry);
  ASSERT_TRUE(contains(registry.names(), "libcamera"));
  std::unique_ptr<Driver> driver = registry.create("libcamera");
  ASSERT_NE(driver, nullptr);
  EXPECT_EQ(driver->name(), "libcamera");
}

TEST(LibcameraRegistration, IsAmongTheBuiltinDrivers) {
  DriverRegistry registry;
  registerBuiltinDrivers(registry);
  EXPECT_TRUE(contains(registry.names(), "libcamera"));
}

TEST_F(NoCamera, EnumerateIsEmptyAndTheDriverSaysWhy) {
  EXPECT_TRUE(driver_.enumerate().empty());
  const Status status = driver_.checkCameras();
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("libcamera v0."));
  EXPECT_THAT(status.message(), HasSubstr("no camera found"));
}

TEST_F(NoCamera, DriversShareOneCameraManager) {
  // libcamera refuses a second started CameraManager in one process; both must still work.
  LibcameraDriver second;
  EXPECT_TRUE(driver_.enumerate().empty());
  EXPECT_TRUE(second.enumerate().empty());
  EXPECT_THAT(second.checkCameras().message(), HasSubstr("no camera found"));
}

TEST_F(NoCamera, OpenByIdNamesTheIdAndWhatExists) {
  const std::string error = openError(driver_, configFor("/base/soc/i2c0mux/i2c@1/imx219@10"));
  EXPECT_THAT(error, HasSubstr("camera '/base/soc/i2c0mux/i2c@1/imx219@10'"));
  EXPECT_THAT(error, HasSubstr("found no camera"));
}

TEST_F(NoCamera, OpenByIndexNamesTheIndexAndWhatExists) {
  const std::string error = openError(driver_, configFor("0"));
  EXPECT_THAT(error, HasSubstr("camera index 0"));
  EXPECT_THAT(error, HasSubstr("found no camera"));
}

TEST_F(NoCamera, OpenOfFirstCameraSaysThereIsNone) {
  const std::string error = openError(driver_, configFor(""));
  EXPECT_THAT(error, HasSubstr("the first camera (device is empty)"));
  EXPECT_THAT(error, HasSubstr("found no camera"));
}

// Refused by the config check: the message is about the config, not about a missing camera.
void expectRefused(const CameraConfig& config, const std::string& expected) {
  LibcameraDriver driver;
  const std::string error = openError(driver, config);
  EXPECT_THAT(error, HasSubstr(expected));
  EXPECT_THAT(error, ::testing::Not(HasSubstr("found no camera")));
  EXPECT_FALSE(checkLibcameraConfig(config).ok());
}

TEST(LibcameraConfig, RefusesTriggerModes) {
  CameraConfig config = configFor("0");
  config.trigger = TriggerMode::kSoftware;
  expectRefused(config, "trigger mode software is not supported");
  config.trigger = TriggerMode::kHardwareLine;
  config.trigger_line = "Line1";
  expectRefused(config, "trigger mode hardware line is not supported");
}

TEST(LibcameraConfig, RefusesZeroSize) {
  CameraConfig config = configFor("usb-cam");
  config.width = 0;
  expectRefused(config, "camera 'usb-cam': size 0x580 is not possible");
  config = configFor("usb-cam");
  config.height = 0;
  expectRefused(config, "size 780x0 is not possible: width and height must be positive");
}

TEST(LibcameraConfig, RefusesBadRateExposureAndFormat) {
  CameraConfig config = configFor("");
  config.fps = 0;
  expectRefused(config, "fps 0 is not possible");
  config = configFor("");
  config.exposure_us = -5.0;
  expectRefused(config, "exposure_us -5 is not possible");
  config = configFor("");
  config.pixel_format = "SBGGR10";
  expectRefused(config, "pixel format 'SBGGR10' is not supported by mocapd; use one of R8, YUYV");
}

TEST(LibcameraConfig, AcceptsTheDefaultConfig) {
  EXPECT_TRUE(checkLibcameraConfig(configFor("")).ok());
  CameraConfig config = configFor("");
  config.pixel_format = "GREY";
  EXPECT_TRUE(checkLibcameraConfig(config).ok());
}

}  // namespace
}  // namespace mocap
