// Fuzzes the camera rig (calibration) reader, tracker/model/camera.h's loadRig, which reads OpenCV
// FileStorage YAML with yaml-cpp: each input is written to a scratch file first.
#include <stdexcept>

#include "tests/fuzz/fuzz_support.h"
#include "tracker/model/camera.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const mocap::fuzz::ScratchDirectory scratch;
  const std::string path = scratch.write("rig.yaml", mocap::fuzz::asText(data, size)).string();
  try {
    const mocap::Rig rig = mocap::loadRig(path);
    for (const mocap::CameraModel& camera : rig) {
      Eigen::Vector2d pixel;
      camera.project(Eigen::Vector3d(0.1, 0.2, 3.0), pixel);
      camera.backProject(Eigen::Vector2d(camera.width / 2.0, camera.height / 2.0));
    }
  } catch (const std::runtime_error& e) {
    mocap::fuzz::requireNamesSource(e, path);
  }
  return 0;
}
