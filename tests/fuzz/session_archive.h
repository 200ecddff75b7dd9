// The session fuzz target's input: a whole session directory in one file, each entry a line
// "=== <path inside the session>" followed by the file's bytes up to the next such line, e.g.
//   === manifest.yaml
//   format_version: 1 ...
//   === cam0/000000.png
//   <PNG bytes>
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace mocap::fuzz {

inline constexpr std::string_view kArchiveMarker = "=== ";

// The entries of `archive`; names that could leave the session directory (absolute, "..") and
// entries past the first 16 are dropped.
inline std::vector<std::pair<std::string, std::string_view>> splitArchive(std::string_view archive) {
  std::vector<std::pair<std::string, std::string_view>> entries;
  std::size_t header = archive.rfind(kArchiveMarker, 0) == 0 ? 0 : archive.find("\n=== ");
  if (header != std::string_view::npos && header != 0) ++header;
  while (header != std::string_view::npos && entries.size() < 16) {
    const std::size_t name_end = archive.find('\n', header);
    if (name_end == std::string_view::npos) break;
    const std::size_t name_start = header + kArchiveMarker.size();
    std::string name(archive.substr(name_start, name_end - name_start));
    std::size_t next = archive.find("\n=== ", name_end);
    const std::size_t content_end = next == std::string_view::npos ? archive.size() : next;
    if (!name.empty() && name.front() != '/' && name.find("..") == std::string::npos)
      entries.emplace_back(std::move(name), archive.substr(name_end + 1, content_end - name_end - 1));
    header = next == std::string_view::npos ? next : next + 1;
  }
  return entries;
}

}  // namespace mocap::fuzz
