// Fuzzes the daemon's configuration (server/config.h). The daemon catches ConfigError alone when it
// reads its file, so any other exception escaping parseConfig is a finding.
#include "server/config.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  // Relative paths in the input resolve inside an empty directory: they name no file.
  static const mocap::fuzz::ScratchDirectory scratch;
  constexpr const char* kSource = "fuzz_mocapd.yaml";
  try {
    mocap::parseConfig(mocap::fuzz::asText(data, size), kSource, scratch.path().string());
  } catch (const mocap::ConfigError& e) {
    mocap::fuzz::requireNamesSource(e, kSource);
  }
  return 0;
}
