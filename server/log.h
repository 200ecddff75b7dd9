// The daemon's log: one line per event on stderr (journald adds the time), with a level, written
// whole so lines of concurrent threads never interleave. Per-frame events are never logged.
#pragma once

#include <sstream>

#include "server/config.h"

namespace mocap {

void setLogLevel(LogLevel level);
bool logEnabled(LogLevel level);

// Collects one line and writes it when destroyed: LogLine(LogLevel::kInfo) << "listening on " << a;
class LogLine {
 public:
  explicit LogLine(LogLevel level) : level_(level) {}
  ~LogLine();
  LogLine(const LogLine&) = delete;
  LogLine& operator=(const LogLine&) = delete;

  template <typename T>
  LogLine& operator<<(const T& value) {
    if (logEnabled(level_)) text_ << value;
    return *this;
  }

 private:
  LogLevel level_;
  std::ostringstream text_;
};

inline LogLine logDebug() { return LogLine(LogLevel::kDebug); }
inline LogLine logInfo() { return LogLine(LogLevel::kInfo); }
inline LogLine logWarning() { return LogLine(LogLevel::kWarning); }
inline LogLine logError() { return LogLine(LogLevel::kError); }

}  // namespace mocap
