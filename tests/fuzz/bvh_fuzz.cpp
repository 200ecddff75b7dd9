// Fuzzes the BVH reader (tracker/motion/bvh.h): parsing, then what loading does after it (units,
// reference pose) and forward kinematics of the frames the file holds.
#include <stdexcept>

#include "tests/fuzz/fuzz_support.h"
#include "tracker/motion/bvh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  constexpr const char* kSource = "fuzz.bvh";
  mocap::Bvh bvh;
  try {
    bvh = mocap::parseBvh(mocap::fuzz::asText(data, size), kSource);
  } catch (const std::runtime_error& e) {
    mocap::fuzz::requireNamesSource(e, kSource);
    return 0;
  }
  mocap::bvhRestPositions(bvh.skeleton);
  for (std::size_t f = 0; f < bvh.motion.frames.size() && f < 4; ++f)
    mocap::bvhJointPositions(bvh.skeleton, bvh.motion.frames[f]);
  try {
    // kAuto refuses a skeleton of no person's size with std::runtime_error.
    mocap::prepareBvh(bvh, {});
  } catch (const std::runtime_error&) {
  }
  return 0;
}
