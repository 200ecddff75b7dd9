// Recording control: opens and closes the session the mask thread records each frame set into
// (StartRecording, StopRecording), notes the background each camera's silhouettes come from so a
// replay can extract them alike, and keeps a recording and a body change apart: a session stores
// one body, so no recording opens while a fit that will apply its body is under way, and no such
// fit starts while a recording is open.
//
// Threads: start(), stop(), status() and backgroundsInUse() from any thread (the service's, the
// pipeline's stop()), but start() from one at the daemon's scheduling policy, which the recorder's
// writers inherit (not the web view's idle one); tap() from the mask thread; noteBackground() from
// the mask thread (or the pipeline's constructor, before it starts); reserveBodyChange() and
// releaseBodyChange() from the body-fit job (the requester's thread, the mask or fit thread).
// status() takes no lock the others wait for, so a reader at idle priority (the web view's
// /api/status) that is preempted mid-read holds up neither the mask thread nor the writers.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "drivers/record/recorder.h"
#include "drivers/sync/frame_synchronizer.h"
#include "server/body_fit_job.h"
#include "server/config.h"
#include "server/opened_camera.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/vision/background_model.h"

namespace mocap {

struct RecordingStatus {
  bool active = false;
  std::string path;  // relative to the recording directory
  uint64_t frame_sets = 0;
  int64_t started_wall_ns = 0;
  // Why the recording stopped on its own: free space under recording.min_free_mb, or a write
  // that failed (ENOSPC, EIO); empty while it runs or once stopped on request.
  std::string stopped;
};

// Why a recording request failed, so the service can pick the gRPC code.
enum class RecordingError {
  kNone,
  kBadPath,
  kOutsideRoot,
  kNotConfigured,
  kBusy,
  kNotRecording,
  kIo
};
struct RecordingResult {
  RecordingError error = RecordingError::kNone;
  std::string message;
  RecordingStatus status;
};

// What a session stores of the tracking besides the frames.
struct RecordedTracking {
  const BodyModel* configured_body = nullptr;
  // The body the truth is of when not the tracked one (the scene's subject); null otherwise.
  std::shared_ptr<const BodyModel> reference_model;
  // The true pose of a frame, when the source knows it (see PipelineInputs::reference_pose).
  std::function<Eigen::VectorXd(uint64_t frame_sequence)> truth;
  // The body tracked when the session opens.
  std::function<TrackedBody()> tracked_body;
};

class RecordingControl {
 public:
  // The configuration, rig and cameras are borrowed and must outlive it. `scene_backgrounds`: per
  // camera, the background a recording stores while no other is in use (the fake scene's empty
  // room with true silhouettes).
  RecordingControl(const ServerConfig& config, const Rig& rig,
                   const std::vector<OpenedCamera>& cameras, RecordedTracking tracking,
                   std::vector<std::shared_ptr<const BackgroundModel>> scene_backgrounds);

  RecordingResult start(const std::string& relative_path);
  RecordingResult stop();
  // The recording as last started or closed, with the frame sets written as of the mask thread's
  // latest tap(); a recorder that stopped on its own shows as stopped from the next tap().
  RecordingStatus status() const;

  // Mask thread: notes the cameras' latest frames and records the set while a session is open.
  // Closes a session whose recorder stopped on its own (the disk floor, a failed write).
  void tap(const FrameSet& set, uint64_t frame_sequence);
  // Camera's silhouettes are extracted against `background` from its next frame on (null:
  // thresholded, or none): an open session notes it from that frame.
  void noteBackground(std::size_t camera, std::shared_ptr<const BackgroundModel> background);
  // Per camera, the background noted last.
  std::vector<std::shared_ptr<const BackgroundModel>> backgroundsInUse() const;

  // A fit that will apply its body: false (and nothing reserved) while a session is open; else no
  // session opens until releaseBodyChange().
  bool reserveBodyChange();
  void releaseBodyChange();

 private:
  RecordingStatus statusLocked() const;
  // Under mutex_, so what status() reads changes in the order the recording does.
  void publishLocked(RecordingStatus status);
  RecorderOptions recorderOptions() const;
  // Closes `recorder` (taken out of recorder_), keeps its final status and logs it.
  RecordingResult finish(std::unique_ptr<Recorder> recorder, RecordingStatus status);
  // Under mutex_: the cameras as a session describes them, or why it cannot open yet.
  RecordingResult describeCamerasLocked(std::vector<SessionCamera>& cameras) const;

  const ServerConfig& config_;
  const Rig& rig_;
  const std::vector<OpenedCamera>& cameras_;
  const RecordedTracking tracking_;

  // The recorder tap: the mask thread writes each frame set while a recording is open.
  mutable std::mutex mutex_;
  std::unique_ptr<Recorder> recorder_;
  std::string path_;
  int64_t started_wall_ns_ = 0;
  RecordingStatus last_;
  std::vector<int> camera_cv_types_;  // of the latest frames, -1 before the first
  // Per camera: the background a recording stores for it (the one its silhouettes are extracted
  // against, or the scene's with true silhouettes; null: thresholded), and the sequence its next
  // frame will have at the least (one past the latest).
  std::vector<std::shared_ptr<const BackgroundModel>> backgrounds_in_use_;
  std::vector<uint64_t> next_frame_sequences_;

  // What status() reads instead of taking mutex_, which the mask thread takes every frame set and
  // holds while it takes the recorder's lock, which the writers take every set: the status as of
  // the last start or close (swapped only then, a few times a session; a load holds the pointer
  // only to count a reference, so even a reader preempted there can only delay such a swap), and
  // the sets written so far (stored by the mask thread each set, never waiting).
  std::atomic<std::shared_ptr<const RecordingStatus>> published_;
  std::atomic<uint64_t> sets_written_{0};

  // Held by reserveBodyChange() and by start() throughout, so a recording never opens with one
  // body while the tracker switches to another.
  std::mutex session_mutex_;
  bool body_change_reserved_ = false;
};

}  // namespace mocap
