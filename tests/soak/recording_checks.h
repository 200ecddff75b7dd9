// The soak's check of its recordings, on a thread of its own at the lowest priority: each session
// is read back with the project's reader, every image decoded, and compared with what the daemon
// said it wrote; then it is deleted, unless kept.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace mocap::soak {

struct RecordingCheck {
  std::filesystem::path directory;
  // Stopped by StopRecording, or cut short by SIGKILL (or a crash).
  bool killed = false;
  // Closed: the frame sets StopRecording reported. Killed: the last count GetStatus reported
  // before the kill, which the writer may not have put on disk yet.
  uint64_t reported_sets = 0;

  // Filled in by the check.
  bool readable = false;
  std::string error;               // why the reader refused it
  uint64_t sets_read = 0;          // every one with all its images decoded
  uint64_t sets_lost = 0;          // closed: reported but not read back
  std::vector<std::string> notes;  // what the reader tolerated (a partial last line)
};

class RecordingChecker {
 public:
  explicit RecordingChecker(bool keep) : keep_(keep) {}
  ~RecordingChecker();
  void start();
  void add(RecordingCheck check);
  // Waits for every check queued so far, then stops the thread.
  std::vector<RecordingCheck> finish();

 private:
  void run();
  static void check(RecordingCheck& recording);

  const bool keep_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<RecordingCheck> queue_;
  std::vector<RecordingCheck> done_;
  bool finishing_ = false;
  std::thread thread_;
};

}  // namespace mocap::soak
