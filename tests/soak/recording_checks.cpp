// The soak's check of its recordings: SessionReader with every image decoded.
#include "recording_checks.h"

#include <sys/resource.h>
#include <unistd.h>

#include "drivers/record/session_reader.h"

namespace mocap::soak {

RecordingChecker::~RecordingChecker() {
  if (thread_.joinable()) finish();
}

void RecordingChecker::start() {
  thread_ = std::thread([this] {
    // Linux nices a thread on its own: decoding sessions must not take the daemon's cores.
    setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 19);
    run();
  });
}

void RecordingChecker::add(RecordingCheck check) {
  std::lock_guard<std::mutex> lock(mutex_);
  queue_.push_back(std::move(check));
  changed_.notify_all();
}

std::vector<RecordingCheck> RecordingChecker::finish() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    finishing_ = true;
    changed_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
  return done_;
}

void RecordingChecker::run() {
  for (;;) {
    RecordingCheck recording;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [this] { return finishing_ || !queue_.empty(); });
      if (queue_.empty()) return;
      recording = std::move(queue_.front());
      queue_.pop_front();
    }
    check(recording);
    if (!keep_) {
      std::error_code ignored;
      std::filesystem::remove_all(recording.directory, ignored);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    done_.push_back(std::move(recording));
  }
}

void RecordingChecker::check(RecordingCheck& recording) {
  SessionReadOptions options;
  options.decode_all = true;
  Expected<std::unique_ptr<SessionReader>> reader =
      SessionReader::open(recording.directory, options);
  if (!reader.ok()) {
    recording.error = reader.error();
    return;
  }
  recording.readable = true;
  recording.sets_read = reader.value()->sets().size();
  recording.notes = reader.value()->notes();
  if (!recording.killed && recording.sets_read < recording.reported_sets)
    recording.sets_lost = recording.reported_sets - recording.sets_read;
}

}  // namespace mocap::soak
