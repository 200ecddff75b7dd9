// The recorder: path checks, session creation, and the writer thread's crash-safe write order.
#include "drivers/record/recorder.h"

#include "drivers/record/png_writer.h"

#include <fcntl.h>
#include <pthread.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <future>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "drivers/clock.h"

namespace mocap {
namespace fs = std::filesystem;
namespace {

std::string errnoText(const std::string& what, const std::string& path) {
  return what + " " + path + ": " + std::strerror(errno);
}

std::string utcNowIso8601() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

bool writeAll(int fd, const void* data, std::size_t size) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t written = ::write(fd, bytes, size);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return false;
    bytes += written;
    size -= static_cast<std::size_t>(written);
  }
  return true;
}

bool isInside(const fs::path& root, const fs::path& path) {
  auto r = root.begin();
  auto p = path.begin();
  for (; r != root.end(); ++r, ++p) {
    if (p == path.end() || *r != *p) return false;
  }
  return true;
}

// Writes a small file atomically (temp name, fsync, rename), so a crash never leaves half of it.
Status writeFileAtomically(const fs::path& path, const std::string& content) {
  const std::string temp = path.string() + ".tmp";
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Status::Error(errnoText("cannot create", temp));
  const bool ok = writeAll(fd, content.data(), content.size()) && ::fsync(fd) == 0;
  const std::string error = ok ? "" : errnoText("cannot write", temp);
  ::close(fd);
  if (!ok) return Status::Error(error);
  if (::rename(temp.c_str(), path.c_str()) != 0) return Status::Error(errnoText("cannot rename to", path.string()));
  return Status::Ok();
}

std::string megabytes(uint64_t bytes) { return std::to_string(bytes / 1'000'000) + " MB"; }

}  // namespace

Expected<uint64_t> freeBytesAt(const fs::path& path) {
  struct statvfs info {};
  if (::statvfs(path.c_str(), &info) != 0) return Status::Error(errnoText("cannot statvfs", path.string()));
  return static_cast<uint64_t>(info.f_bavail) * info.f_frsize;
}

Expected<fs::path> resolveInsideRoot(const fs::path& root, const fs::path& dir) {
  std::error_code error;
  const fs::path canonical_root = fs::canonical(root, error);
  if (error || !fs::is_directory(canonical_root)) {
    return Status::Error("recording root " + root.string() + " is not an existing directory");
  }
  if (dir.empty()) return Status::Error("session path is empty");
  for (const fs::path& part : dir) {
    if (part == "..") return Status::Error("session path " + dir.string() + " contains '..'");
  }
  const fs::path full = dir.is_absolute() ? dir : canonical_root / dir;
  // Resolves every symlink along the part that exists, so a link pointing out is caught.
  const fs::path resolved = fs::weakly_canonical(full, error);
  if (error) return Status::Error("session path " + full.string() + ": " + error.message());
  if (!isInside(canonical_root, resolved) || resolved == canonical_root) {
    return Status::Error("session path " + dir.string() + " is outside the recording root " +
                         canonical_root.string());
  }
  return resolved;
}

Recorder::Recorder(fs::path root, RecorderOptions options)
    : root_(std::move(root)), options_(options) {}

Recorder::~Recorder() { close(); }

Status Recorder::open(const fs::path& dir, const Rig& rig, const std::vector<SessionCamera>& cameras,
                      const SessionTracking& tracking) {
  if (isOpen()) return Status::Error("recorder: already recording to " + session_.string());
  if (cameras.empty()) return Status::Error("recorder: no cameras to record");
  if (!rig.empty() && rig.size() != cameras.size()) {
    return Status::Error("recorder: the rig has " + std::to_string(rig.size()) + " cameras, the session " +
                         std::to_string(cameras.size()));
  }
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    if (cvTypeOfPixelFormat(cameras[i].pixel_format) < 0 || cameras[i].width <= 0 || cameras[i].height <= 0) {
      return Status::Error("recorder: camera " + std::to_string(i) + " (" + cameras[i].name +
                           "): needs a positive size and pixel format " + kPixelGray + " or " + kPixelBgr);
    }
  }
  Expected<fs::path> resolved = resolveInsideRoot(root_, dir);
  if (!resolved.ok()) return Status::Error("recorder: " + resolved.error());
  if (Status room = checkFreeSpace(); !room.ok()) return room;
  const fs::path session = resolved.value();
  std::error_code error;
  if (fs::exists(session, error)) {
    if (!fs::is_directory(session, error)) return Status::Error("recorder: " + session.string() + " exists and is not a directory");
    if (!fs::is_empty(session, error)) return Status::Error("recorder: " + session.string() + " exists and is not empty");
  }
  fs::create_directories(session, error);
  if (error) return Status::Error("recorder: cannot create " + session.string() + ": " + error.message());
  // Checked again now that it exists: a symlink swapped in meanwhile must not lead us out.
  Expected<fs::path> created = resolveInsideRoot(root_, session);
  if (!created.ok()) return Status::Error("recorder: " + created.error());

  SessionManifest manifest;
  manifest.software_version = MOCAP_VERSION;
  manifest.start_time_utc = utcNowIso8601();
  manifest.start_monotonic_ns = monotonicNowNs();
  manifest.calibration_file = rig.empty() ? "" : kCalibrationFile;
  manifest.body_model_file = tracking.body ? kBodyModelFile : "";
  manifest.truth_body_model_file = tracking.truth_body ? kTruthBodyModelFile : "";
  manifest.tracker_settings = tracking.tracker_settings;
  manifest.images = options_.images;
  manifest.cameras = cameras;
  if (!rig.empty()) {
    try {
      saveRig((session / kCalibrationFile).string(), rig);
    } catch (const std::exception& e) {
      return Status::Error(std::string("recorder: ") + e.what());
    }
  }
  for (const auto& [body, file] : {std::pair{tracking.body, kBodyModelFile},
                                   std::pair{tracking.truth_body, kTruthBodyModelFile}}) {
    if (!body) continue;
    if (Status status = writeFileAtomically(session / file, formatBodyModel(*body)); !status.ok())
      return Status::Error("recorder: " + status.message());
  }
  files_.assign(cameras.size(), CameraFiles{});
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const fs::path camera_dir = session / cameraDirectoryName(static_cast<int>(i));
    fs::create_directory(camera_dir, error);
    if (error) {
      closeFiles();
      return Status::Error("recorder: cannot create " + camera_dir.string() + ": " + error.message());
    }
    const std::string index_path = (camera_dir / kIndexFile).string();
    files_[i].dir_fd = ::open(camera_dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    files_[i].index_fd = ::open(index_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    const std::string header = std::string(kIndexHeader) + "\n";
    if (files_[i].dir_fd < 0 || files_[i].index_fd < 0 ||
        !writeAll(files_[i].index_fd, header.data(), header.size())) {
      const std::string message = errnoText("recorder: cannot create", index_path);
      closeFiles();
      return Status::Error(message);
    }
  }
  const std::string sets_path = (session / kSetsFile).string();
  sets_fd_ = ::open(sets_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  const std::string sets_header = std::string(kSetsHeader) + "\n";
  if (sets_fd_ < 0 || !writeAll(sets_fd_, sets_header.data(), sets_header.size())) {
    const std::string message = errnoText("recorder: cannot create", sets_path);
    closeFiles();
    return Status::Error(message);
  }
  const std::string backgrounds_path = (session / kBackgroundsFile).string();
  backgrounds_fd_ =
      ::open(backgrounds_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  const std::string backgrounds_header = std::string(kBackgroundsHeader) + "\n";
  if (backgrounds_fd_ < 0 ||
      !writeAll(backgrounds_fd_, backgrounds_header.data(), backgrounds_header.size())) {
    const std::string message = errnoText("recorder: cannot create", backgrounds_path);
    closeFiles();
    return Status::Error(message);
  }
  truth_dof_count_ = tracking.truth_dofs.size();
  if (!tracking.truth_dofs.empty()) {
    const std::string truth_path = (session / kTruthFile).string();
    const std::string header = truthHeader(tracking.truth_dofs) + "\n";
    truth_fd_ = ::open(truth_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (truth_fd_ < 0 || !writeAll(truth_fd_, header.data(), header.size())) {
      const std::string message = errnoText("recorder: cannot create", truth_path);
      closeFiles();
      return Status::Error(message);
    }
  }
  // The manifest goes last: a directory without one is not a session, whatever else it holds.
  if (Status status = writeFileAtomically(session / kManifestFile, emitManifest(manifest)); !status.ok()) {
    closeFiles();
    return Status::Error("recorder: " + status.message());
  }
  session_ = session;
  cameras_ = cameras;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    silhouettes_.clear();
    silhouettes_.resize(cameras.size());
    stats_ = {};
    queue_.clear();
    background_queue_.clear();
    closing_ = false;
  }
  last_index_sync_ns_ = monotonicNowNs();
  writer_ = std::thread([this] { writerLoop(); });
  background_writer_ = std::thread([this] { backgroundWriterLoop(); });
  // Named here, not by the threads themselves, so the names are set once open() returns; the
  // writer's encoding helpers inherit its name.
  pthread_setname_np(writer_.native_handle(), kThreadName);
  pthread_setname_np(background_writer_.native_handle(), kThreadName);
  return Status::Ok();
}

Status Recorder::checkFreeSpace() const {
  if (options_.min_free_bytes == 0) return Status::Ok();
  const fs::path where = session_.empty() ? root_ : session_;
  const Expected<uint64_t> free = options_.free_space ? options_.free_space(where) : freeBytesAt(where);
  if (!free.ok()) return Status::Error("recorder: " + free.error());
  if (free.value() >= options_.min_free_bytes) return Status::Ok();
  return Status::Error("recorder: " + megabytes(free.value()) + " free on the file system of " +
                       where.string() + ", under the floor of " +
                       megabytes(options_.min_free_bytes) + " (recording.min_free_mb)");
}

bool Recorder::stopped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return !stats_.stopped.empty();
}

void Recorder::write(const FrameSet& set, SetTruth truth) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!writer_.joinable() || closing_ || !stats_.stopped.empty()) return;
    ++stats_.sets_received;
    // Drop the newest rather than block: the pipeline's latency matters more than the recording,
    // and the queued sets are already in time order.
    if (queue_.size() >= options_.queue_sets) {
      ++stats_.sets_dropped;
      return;
    }
    queue_.push_back({set, std::move(truth)});
  }
  queued_.notify_one();
}

void Recorder::writeBackground(int camera, uint64_t from_sequence,
                               std::shared_ptr<const BackgroundModel> background) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!writer_.joinable() || closing_ || !stats_.stopped.empty()) return;
    if (camera >= 0 && static_cast<std::size_t>(camera) < silhouettes_.size())
      silhouettes_[camera].noted.emplace_back(from_sequence, background);
    // Without images a background extracts nothing at replay: the silhouettes are the record.
    if (options_.images == ImageMode::kNone) return;
    background_queue_.push_back({{from_sequence, camera, ""}, std::move(background)});
  }
  backgrounds_queued_.notify_one();
}

template <typename Job>
bool Recorder::nextJob(std::deque<Job>& queue, std::condition_variable& queued, Job& job) {
  std::unique_lock<std::mutex> lock(mutex_);
  queued.wait(lock, [&] { return closing_ || !queue.empty(); });
  if (queue.empty()) return false;  // closing and drained
  job = std::move(queue.front());
  queue.pop_front();
  return true;
}

void Recorder::backgroundWriterLoop() {
  BackgroundJob job;
  while (nextJob(background_queue_, backgrounds_queued_, job) && !stopped())
    storeBackground(job.record, job.model.get());
}

bool Recorder::storeBackground(BackgroundRecord record, const BackgroundModel* model) {
  if (record.camera < 0 || static_cast<std::size_t>(record.camera) >= cameras_.size()) {
    fail("background of camera " + std::to_string(record.camera) + ", which the session lacks");
    return false;
  }
  if (model) {
    char name[40];
    std::snprintf(name, sizeof name, "background_%06llu.yml",
                  static_cast<unsigned long long>(record.from_sequence));
    record.file = name;
    try {
      saveBackground((session_ / cameraDirectoryName(record.camera) / name).string(), *model);
    } catch (const std::exception& e) {
      fail(e.what());
      return false;
    }
  }
  // The commit record: written after the model is on disk (saveBackground flushes it).
  const std::string line = formatBackgroundLine(record) + "\n";
  if (!writeAll(backgrounds_fd_, line.data(), line.size()) ||
      (options_.durability == Durability::kPowerLoss && ::fdatasync(backgrounds_fd_) != 0)) {
    fail(errnoText("cannot append to", (session_ / kBackgroundsFile).string()));
    return false;
  }
  return true;
}

Status Recorder::close() {
  if (!writer_.joinable()) return Status::Ok();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closing_ = true;
  }
  queued_.notify_one();
  backgrounds_queued_.notify_one();
  writer_.join();
  background_writer_.join();
  syncIndexes();
  closeFiles();
  std::lock_guard<std::mutex> lock(mutex_);
  if (stats_.write_errors > 0) return Status::Error("recorder: " + stats_.last_error);
  return Status::Ok();
}

RecorderStats Recorder::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

void Recorder::writerLoop() {
  QueuedSet queued;
  while (nextJob(queue_, queued_, queued)) {
    // Checked before each set, so a set is either written whole or not begun.
    if (Status room = checkFreeSpace(); !room.ok()) stop(room.message());
    if (stopped()) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.sets_discarded;
      break;
    }
    if (writeSet(queued)) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.sets_written;
    }
    if (options_.durability == Durability::kPowerLoss && monotonicNowNs() - last_index_sync_ns_ > 1'000'000'000) {
      syncIndexes();
    }
  }
  // Once stopped, the sets still queued are never written: a full or failing disk would only
  // lose them midway.
  std::lock_guard<std::mutex> lock(mutex_);
  stats_.sets_discarded += queue_.size();
  queue_.clear();
}

bool Recorder::writeSet(const QueuedSet& queued) {
  const FrameSet& set = queued.set;
  std::string present(cameras_.size(), '0');
  std::vector<int> accepted;
  uint64_t rejected = 0;
  for (std::size_t c = 0; c < set.frames.size(); ++c) {
    if (!set.frames[c]) continue;
    const cv::Mat& image = set.frames[c]->image;
    if (c >= cameras_.size() || image.cols != cameras_[c].width || image.rows != cameras_[c].height ||
        image.type() != cvTypeOfPixelFormat(cameras_[c].pixel_format)) {
      ++rejected;
      continue;
    }
    accepted.push_back(static_cast<int>(c));
  }
  if (rejected > 0) {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.frames_rejected += rejected;
  }
  if (accepted.empty()) return false;
  // Extraction and encoding are the bottleneck (libpng's row filtering alone takes tens of ms
  // for a noisy 780x580 BGR frame): the cameras of a set are done in parallel, the first on this
  // thread.
  std::vector<EncodedFrame> encoded(accepted.size());
  std::vector<std::future<bool>> helpers;
  const auto encode = [&](std::size_t k) {
    return encodeFrame(accepted[k], *set.frames[accepted[k]], encoded[k]);
  };
  for (std::size_t k = 1; k < accepted.size(); ++k) helpers.push_back(std::async(std::launch::async, encode, k));
  bool encoded_all = encode(0);
  for (std::future<bool>& helper : helpers) encoded_all = helper.get() && encoded_all;
  if (!encoded_all) {
    fail("cannot encode the images of set " + std::to_string(set.sequence));
    return false;
  }
  std::vector<std::pair<int, IndexRecord>> records;
  for (std::size_t k = 0; k < accepted.size(); ++k) {
    const int c = accepted[k];
    const Frame& frame = *set.frames[c];
    IndexRecord record{set.sequence, frame.sequence, frame.timestamp_ns, frame.dropped_before, frame.corrupt, "", ""};
    char number[24];
    std::snprintf(number, sizeof number, "%06llu", static_cast<unsigned long long>(files_[c].next_image));
    if (!encoded[k].image.empty()) record.file = number + std::string(imageExtension(options_.images));
    if (!encoded[k].silhouette.empty()) record.silhouette = number + std::string("_silhouette.png");
    if ((!record.file.empty() && !writeFile(c, record.file, encoded[k].image)) ||
        (!record.silhouette.empty() && !writeFile(c, record.silhouette, encoded[k].silhouette)))
      return false;
    ++files_[c].next_image;
    present[c] = '1';
    records.emplace_back(c, std::move(record));
  }
  if (options_.durability == Durability::kPowerLoss) {
    // The renames must be on disk before any index line that names them.
    for (const auto& [camera, record] : records) {
      if (::fsync(files_[camera].dir_fd) != 0) {
        fail(errnoText("cannot sync", (session_ / cameraDirectoryName(camera)).string()));
        return false;
      }
    }
  }
  for (const auto& [camera, record] : records) {
    const std::string line = formatIndexLine(record) + "\n";
    if (!writeAll(files_[camera].index_fd, line.data(), line.size())) {
      fail(errnoText("cannot append to", (session_ / cameraDirectoryName(camera) / kIndexFile).string()));
      return false;
    }
  }
  // The commit record: a set counts only once this line is whole.
  const std::string line = formatSetLine({set.sequence, set.timestamp_ns, present}) + "\n";
  if (!writeAll(sets_fd_, line.data(), line.size())) {
    fail(errnoText("cannot append to", (session_ / kSetsFile).string()));
    return false;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.frames_written += records.size();
  }
  const Eigen::VectorXd& dofs = queued.truth.dofs;
  if (truth_fd_ >= 0 && dofs.size() == static_cast<long>(truth_dof_count_)) {
    const std::string truth =
        formatTruthLine({queued.truth.frame_sequence,
                         std::vector<double>(dofs.data(), dofs.data() + dofs.size())}) +
        "\n";
    // The set is committed either way: a failure here stops the recording after it.
    if (!writeAll(truth_fd_, truth.data(), truth.size()))
      fail(errnoText("cannot append to", (session_ / kTruthFile).string()));
  }
  return true;
}

bool Recorder::encodeFrame(int camera, const Frame& frame, EncodedFrame& encoded) {
  const cv::Mat silhouette = extractSilhouette(camera, frame);
  if (!silhouette.empty() && !encodePng(silhouette, options_.png_compression, encoded.silhouette))
    return false;
  switch (options_.images) {
    case ImageMode::kLossless:
      return encodePng(frame.image, options_.png_compression, encoded.image);
    case ImageMode::kCompressed:
      return cv::imencode(".jpg", frame.image, encoded.image,
                          {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality});
    case ImageMode::kNone: return true;
  }
  return false;
}

cv::Mat Recorder::extractSilhouette(int camera, const Frame& frame) {
  CameraSilhouettes& state = silhouettes_[camera];
  std::shared_ptr<const BackgroundModel> reached;
  bool changed = false;
  {
    // The backgrounds noted for this frame on: the mask thread notes them in frame order.
    std::lock_guard<std::mutex> lock(mutex_);
    while (!state.noted.empty() && state.noted.front().first <= frame.sequence) {
      reached = std::move(state.noted.front().second);
      state.noted.pop_front();
      changed = true;
    }
  }
  if (changed) {
    state.extractor.reset();
    try {
      // As a replay would: a fresh extractor per background, adapting over the recorded frames.
      if (reached) state.extractor = std::make_unique<SilhouetteExtractor>(*reached);
    } catch (const std::invalid_argument&) {
      // A background the extractor cannot use: no silhouettes, as the live daemon has none.
    }
  }
  if (state.extractor) {
    if (!state.extractor->extract(frame.image)) return {};
    return state.extractor->silhouette().toMat();
  }
  if (!options_.threshold_without_background) return {};
  cv::Mat gray = frame.image, silhouette;
  if (gray.channels() == 3) cv::cvtColor(frame.image, gray, cv::COLOR_BGR2GRAY);
  cv::threshold(gray, silhouette, 127, 255, cv::THRESH_BINARY);
  return silhouette;
}

bool Recorder::writeFile(int camera, const std::string& name, const std::vector<uint8_t>& bytes) {
  CameraFiles& files = files_[camera];
  const std::string temp = "." + name + ".tmp";
  const std::string shown = (session_ / cameraDirectoryName(camera) / name).string();
  const int fd = ::openat(files.dir_fd, temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    fail(errnoText("cannot create", shown));
    return false;
  }
  bool ok = writeAll(fd, bytes.data(), bytes.size());
  if (ok && options_.durability == Durability::kPowerLoss) ok = ::fdatasync(fd) == 0;
  if (!ok) fail(errnoText("cannot write", shown));
  ::close(fd);
  // Renamed only when whole: a reader never sees a partial file under its final name.
  if (ok && ::renameat(files.dir_fd, temp.c_str(), files.dir_fd, name.c_str()) != 0) {
    fail(errnoText("cannot rename into", shown));
    ok = false;
  }
  if (!ok) ::unlinkat(files.dir_fd, temp.c_str(), 0);
  return ok;
}

void Recorder::syncIndexes() {
  if (options_.durability != Durability::kPowerLoss) return;
  for (const CameraFiles& files : files_) {
    if (files.index_fd >= 0) ::fdatasync(files.index_fd);
  }
  if (sets_fd_ >= 0) ::fdatasync(sets_fd_);
  if (truth_fd_ >= 0) ::fdatasync(truth_fd_);
  last_index_sync_ns_ = monotonicNowNs();
}

void Recorder::fail(const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.write_errors;
    stats_.last_error = message;
  }
  stop(message);
}

void Recorder::stop(const std::string& why) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (stats_.stopped.empty()) stats_.stopped = why;
}

void Recorder::closeFiles() {
  for (CameraFiles& files : files_) {
    if (files.dir_fd >= 0) ::close(files.dir_fd);
    if (files.index_fd >= 0) ::close(files.index_fd);
  }
  files_.clear();
  if (sets_fd_ >= 0) ::close(sets_fd_);
  sets_fd_ = -1;
  if (backgrounds_fd_ >= 0) ::close(backgrounds_fd_);
  backgrounds_fd_ = -1;
  if (truth_fd_ >= 0) ::close(truth_fd_);
  truth_fd_ = -1;
}

}  // namespace mocap
