// The session recorder: writes FrameSets to a session directory (see session_format.h) on its own
// thread, so the caller (the pipeline's consumer) never waits on the disk.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/record/session_format.h"
#include "drivers/status.h"
#include "drivers/sync/frame_synchronizer.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/vision/background_model.h"
#include "tracker/vision/silhouette_extractor.h"

namespace mocap {

// How hard the recorder works to survive a crash.
//  kProcessCrash: images are renamed into place and index lines appended only after the image is
//    written, so a killed process leaves a session readable up to its last committed set; nothing
//    is fsynced (the kernel still holds the data).
//  kPowerLoss (default): in addition, each image is fdatasync'ed before its rename and the camera
//    directories fsync'ed before the set's index lines are written, so an index line never points
//    to an image that a power cut can lose; the index files are fdatasync'ed once a second, so a
//    power cut loses at most about a second of sets.
enum class Durability { kProcessCrash, kPowerLoss };

struct RecorderOptions {
  std::size_t queue_sets = 8;  // sets waiting for the writer before new ones are dropped
  Durability durability = Durability::kPowerLoss;
  // zlib level with the run-length strategy: as fast as storing uncompressed (libpng's filtering
  // dominates), and about 40 % of the raw size on the fake scene's noisy frames.
  int png_compression = 1;
  ImageMode images = ImageMode::kLossless;
  int jpeg_quality = 90;  // images: compressed (1-100)
  // A frame with no background is stored with the thresholded silhouette (the daemon's
  // `before_background: threshold`) instead of none.
  bool threshold_without_background = false;
  // The recording refuses to start, and stops once running, when the file system holding the
  // session has fewer free bytes than this (0: no floor).
  uint64_t min_free_bytes = 0;
  // The free bytes of the file system holding a path (unprivileged users' share); null: statvfs.
  // A seam for tests, which cannot fill a disk.
  std::function<Expected<uint64_t>(const std::filesystem::path&)> free_space = nullptr;
};

// The free bytes for unprivileged users of the file system holding `path` (statvfs).
Expected<uint64_t> freeBytesAt(const std::filesystem::path& path);

struct RecorderStats {
  uint64_t sets_received = 0;
  uint64_t sets_written = 0;
  uint64_t sets_dropped = 0;     // queue full: the disk could not keep up
  uint64_t frames_written = 0;
  uint64_t frames_rejected = 0;  // wrong size or type for its camera, or a camera outside the session
  uint64_t write_errors = 0;     // I/O errors (see last_error); the first stops the recording
  std::string last_error;
  // Why the recording stopped on its own (free space under the floor, an I/O error): sets
  // are no longer taken, the session holds every set committed before. Empty while it runs.
  std::string stopped;
  uint64_t sets_discarded = 0;  // queued when it stopped on its own, never written
};

// What the session was tracked with while it was recorded.
struct SessionTracking {
  const BodyModel* body = nullptr;  // stored as body.yaml; nullptr: none
  // With truth_dofs: the body the true poses are of, when not `body` (same DOFs); stored as
  // truth_body.yaml. nullptr: `body`.
  const BodyModel* truth_body = nullptr;
  std::vector<std::pair<std::string, std::string>> tracker_settings;  // the manifest's `tracker:`
  // The DOF names of the true poses write() is given, in order (truth.csv's columns); empty: the
  // source does not know the truth, no truth.csv.
  std::vector<std::string> truth_dofs;
};

// The true pose of a set's frame, from a source that knows it (the fake scene).
struct SetTruth {
  uint64_t frame_sequence = 0;  // camera_sequence of the set's first frame
  Eigen::VectorXd dofs;         // empty: the subject is not in view, nothing stored
};

// Thread use: open(), write(), writeBackground() and close() from one thread at a time (mocapd
// hands the recorder between its threads under a lock); stats() from any. The writer threads
// (named kThreadName; the cameras of a set are encoded on helpers they start) inherit the
// scheduling policy of the thread calling open(): one at idle priority leaves them starved on a
// busy machine, and close() waiting for them.
class Recorder {
 public:
  static constexpr const char* kThreadName = "mocapd-record";

  // Sessions may only be created under `root` (an existing directory).
  explicit Recorder(std::filesystem::path root, RecorderOptions options = {});
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Creates the session at `dir` (relative to the root, or absolute inside it), writes the manifest
  // and calibration, starts the writer. Refuses a path with "..", one outside the root (also
  // through symlinks), an existing non-empty directory, and a rig whose size is not the camera
  // count (an empty rig is allowed: no calibration file). `tracking` is stored so that a replay
  // tracks the session as it was tracked live.
  Status open(const std::filesystem::path& dir, const Rig& rig, const std::vector<SessionCamera>& cameras,
              const SessionTracking& tracking = {});

  // Fails unless the file system holding the recording root (the session once open) has at least
  // options.min_free_bytes free; the message says how much it has.
  Status checkFreeSpace() const;

  // Queues a set (pixels shared, not copied), with its true pose if the session stores the truth.
  // Never blocks on the disk: drops the set when the queue is full, ignores it once stopped.
  // Frames are matched to cameras by their index in FrameSet::frames. Each frame's silhouette is
  // extracted on the writer's threads against the camera's background (writeBackground).
  void write(const FrameSet& set, SetTruth truth = {});

  // Records that `camera`'s frames from camera_sequence `from_sequence` on are extracted against
  // `background` (null: none, thresholded); from_sequence 0 for the one in use when the recording
  // starts. Never dropped, and stored on a thread of the recorder's, so the caller never waits on
  // the disk (a model takes a few hundred ms).
  void writeBackground(int camera, uint64_t from_sequence,
                       std::shared_ptr<const BackgroundModel> background);

  // Writes what is queued, syncs and stops the writer. Returns the first I/O error, if any.
  Status close();

  bool isOpen() const { return writer_.joinable(); }
  // Stopped on its own (see RecorderStats::stopped): close() it.
  bool stopped() const;
  const std::filesystem::path& sessionPath() const { return session_; }
  RecorderStats stats() const;

 private:
  struct CameraFiles {
    int dir_fd = -1;
    int index_fd = -1;
    uint64_t next_image = 0;
  };
  // A camera's silhouette extraction, on the writer's threads: the backgrounds noted and not yet
  // reached (under mutex_), and the extractor of the one in use (null: none).
  struct CameraSilhouettes {
    std::deque<std::pair<uint64_t, std::shared_ptr<const BackgroundModel>>> noted;
    std::unique_ptr<SilhouetteExtractor> extractor;
  };
  // One frame's encoded files.
  struct EncodedFrame {
    std::vector<uint8_t> image;       // empty with images: none
    std::vector<uint8_t> silhouette;  // empty: none stored
  };
  struct BackgroundJob {
    BackgroundRecord record;
    std::shared_ptr<const BackgroundModel> model;
  };
  // Waits for the next job of `queue` (signalled by `queued`); false once closing and drained.
  template <typename Job>
  bool nextJob(std::deque<Job>& queue, std::condition_variable& queued, Job& job);
  void writerLoop();
  // Stores the queued backgrounds on a thread of their own: a model takes a few hundred ms to
  // write, which would hold up the sets.
  void backgroundWriterLoop();
  // Stores the model (if any), then appends its line to backgrounds.csv; false on an I/O error.
  bool storeBackground(BackgroundRecord record, const BackgroundModel* model);
  struct QueuedSet {
    FrameSet set;
    SetTruth truth;
  };
  // Writes one set: images and silhouettes, then index lines, then the commit line, then its
  // truth line; false if the set was not committed.
  bool writeSet(const QueuedSet& queued);
  // Extracts camera's silhouette of `frame` and encodes what the session keeps of it.
  bool encodeFrame(int camera, const Frame& frame, EncodedFrame& encoded);
  // The silhouette of camera's `frame` against its background then; empty if it has none.
  cv::Mat extractSilhouette(int camera, const Frame& frame);
  // Writes a file of the camera's directory under a temporary name, then renames it.
  bool writeFile(int camera, const std::string& name, const std::vector<uint8_t>& bytes);
  void syncIndexes();
  // Counts an I/O error; the first stops the recording.
  void fail(const std::string& message);
  // Stops taking sets, for `why`; the writer ends after the set it is writing.
  void stop(const std::string& why);
  void closeFiles();

  const std::filesystem::path root_;
  const RecorderOptions options_;
  std::filesystem::path session_;
  std::vector<SessionCamera> cameras_;
  std::vector<CameraFiles> files_;
  std::vector<CameraSilhouettes> silhouettes_;
  int sets_fd_ = -1;
  int backgrounds_fd_ = -1;
  int truth_fd_ = -1;  // -1: no truth stored
  std::size_t truth_dof_count_ = 0;
  int64_t last_index_sync_ns_ = 0;

  std::thread writer_;
  mutable std::mutex mutex_;
  std::condition_variable queued_;
  std::deque<QueuedSet> queue_;
  std::thread background_writer_;
  std::condition_variable backgrounds_queued_;
  std::deque<BackgroundJob> background_queue_;
  bool closing_ = false;
  RecorderStats stats_;
};

// Resolves `dir` against `root` and checks that it stays inside it (no "..", no absolute path
// elsewhere, no symlink leading out). Exposed for the daemon's request checks and for tests.
Expected<std::filesystem::path> resolveInsideRoot(const std::filesystem::path& root,
                                                  const std::filesystem::path& dir);

}  // namespace mocap
