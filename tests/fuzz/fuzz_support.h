// Shared by the libFuzzer targets: the input as text, a scratch directory for parsers that read
// files, and the error contract every parser states ("<source>...: <reason>").
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace mocap::fuzz {

inline std::string asText(const uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// A parser's error must name its input, as the parsers promise. One that does not (a bare
// "stoi", a library's own message) reaches an operator without saying which file is wrong: a
// finding, reported by aborting with the message.
inline void requireNamesSource(const std::exception& error, std::string_view source) {
  if (std::string_view(error.what()).find(source) != std::string_view::npos) return;
  std::fprintf(stderr, "error does not name '%.*s': %s\n", static_cast<int>(source.size()),
               source.data(), error.what());
  std::abort();
}

// One empty directory per fuzzing process, removed at exit; clear() empties it between inputs.
class ScratchDirectory {
 public:
  ScratchDirectory() {
    std::string pattern = (std::filesystem::temp_directory_path() / "mocap-fuzz-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) std::abort();
    path_ = pattern;
  }
  ~ScratchDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;

  const std::filesystem::path& path() const { return path_; }
  void clear() const {
    for (const auto& entry : std::filesystem::directory_iterator(path_))
      std::filesystem::remove_all(entry.path());
  }
  // Writes `bytes` to `relative` inside the directory, creating its parent folders; nothing if a
  // file stands where a folder should.
  std::filesystem::path write(const std::filesystem::path& relative, std::string_view bytes) const {
    const std::filesystem::path file = path_ / relative;
    std::error_code error;
    std::filesystem::create_directories(file.parent_path(), error);
    if (!error)
      std::ofstream(file, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return file;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace mocap::fuzz
