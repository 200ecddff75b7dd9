// Fuzzes the recorded-session reader (drivers/record/session_reader.h) on whole sessions: the
// manifest, calibration, body model, index, sets, backgrounds and truth files, and the PNG images,
// both checked at open and decoded by readFrame. The input is an archive (session_archive.h).
#include "drivers/record/session_reader.h"
#include "tests/fuzz/fuzz_support.h"
#include "tests/fuzz/session_archive.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const mocap::fuzz::ScratchDirectory scratch;
  scratch.clear();
  const std::string archive = mocap::fuzz::asText(data, size);
  for (const auto& [name, bytes] : mocap::fuzz::splitArchive(archive)) scratch.write(name, bytes);
  // Decoding every image at open and checking headers only are separate paths: alternate them.
  mocap::SessionReadOptions options;
  options.decode_all = size % 2 == 1;
  // The reader reports every problem as an error (Expected); an exception is a finding.
  auto reader = mocap::SessionReader::open(scratch.path(), options);
  if (!reader.ok()) return 0;
  const mocap::SessionReader& session = *reader.value();
  for (std::size_t s = 0; s < session.sets().size() && s < 8; ++s)
    for (std::size_t c = 0; c < session.cameras().size(); ++c)
      session.readFrame(s, static_cast<int>(c));
  return 0;
}
