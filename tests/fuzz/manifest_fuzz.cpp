// Fuzzes the session manifest reader (drivers/record/session_format.h) and the line parsers of
// the session's CSV files, which report errors as values: an exception is a finding.
#include "drivers/record/session_format.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::string text = mocap::fuzz::asText(data, size);
  const auto manifest = mocap::parseManifest(text, "fuzz_manifest.yaml");
  if (manifest.ok()) {
    // What the recorder writes must read back.
    const auto again = mocap::parseManifest(mocap::emitManifest(manifest.value()), "emitted");
    if (!again.ok()) {
      std::fprintf(stderr, "an emitted manifest does not read back: %s\n", again.error().c_str());
      std::abort();
    }
  }
  mocap::parseIndexLine(text);
  mocap::parseSetLine(text, 2);
  mocap::parseBackgroundLine(text, 2);
  mocap::parseTruthLine(text, {"root_x", "root_y"});
  return 0;
}
