// Fuzzes the body-model YAML reader (tracker/model/body_model.h), and writing back what it read.
#include <stdexcept>

#include "tests/fuzz/fuzz_support.h"
#include "tracker/model/body_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  constexpr const char* kSource = "fuzz_body.yaml";
  try {
    const mocap::BodyModel model = mocap::parseBodyModel(mocap::fuzz::asText(data, size), kSource);
    // What a recording stores must read back (formatBodyModel's promise).
    const std::string written = mocap::formatBodyModel(model);
    mocap::parseBodyModel(written, "formatted");
  } catch (const std::runtime_error& e) {
    mocap::fuzz::requireNamesSource(e, kSource);
  }
  return 0;
}
