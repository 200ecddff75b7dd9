// The daemon's log: level filter and whole-line writes.
#include "server/log.h"

#include <atomic>
#include <cstdio>

namespace mocap {
namespace {

std::atomic<LogLevel> g_level{LogLevel::kInfo};

const char* levelName(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug: return "debug";
    case LogLevel::kInfo: return "info";
    case LogLevel::kWarning: return "warning";
    case LogLevel::kError: return "error";
  }
  return "?";
}

}  // namespace

void setLogLevel(LogLevel level) { g_level = level; }
bool logEnabled(LogLevel level) { return level >= g_level.load(); }

LogLine::~LogLine() {
  if (!logEnabled(level_)) return;
  const std::string line = std::string("mocapd ") + levelName(level_) + ": " + text_.str() + "\n";
  // One write call per line: stdio locks the stream for its duration.
  std::fwrite(line.data(), 1, line.size(), stderr);
}

}  // namespace mocap
