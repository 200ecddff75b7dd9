// The body-fit job behind FitBody: the mask thread collects the silhouettes of some frame sets,
// a thread of its own fits the body to the subject standing in its fit pose, and with `apply`
// the fitted body becomes the one the tracker tracks.
//
// Threads: request() and appliedBody() from any thread (the service's); open() from the
// pipeline's start(); poll(), add() and close() from the mask thread; takeBodySwitch() from the
// tracker thread; stop() from the pipeline's stop(), once the mask thread has ended.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "server/config.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/search/body_size.h"

namespace mocap {

class RecordingControl;

// Why a body fit failed, so the service can pick the gRPC code. kCannotFit: the body has no
// fit_pose or its root cannot be placed; kCannotApply: asked to apply it in a replay or while a
// recording is open; kNoSubject: none found in the frame sets; kStalled: no frame set with
// silhouettes from every camera for a while; kFailed: the fit threw.
enum class BodyFitError {
  kNone,
  kCannotFit,
  kCannotApply,
  kBusy,
  kNoSubject,
  kStalled,
  kStopped,
  kFailed
};
struct FitBodyResult {
  BodyFitError error = BodyFitError::kNone;
  std::string message;
  int frame_sets_used = 0;    // collected, or once fitted, those the subject was found in
  BodyFit fit;                // without an error
  BodyModel body;             // the fitted body: the fitted model with fit.proportions
  double fit_seconds = 0;     // the fit itself, after the frame sets were collected
  uint32_t body_version = 0;  // applied: the version the tracker tracks it as; else 0
};

// The body the tracker tracks: the configured one (version 0), or the latest fitted one applied.
struct TrackedBody {
  std::shared_ptr<const BodyModel> model;
  uint32_t version = 0;
};

class BodyFitJob {
 public:
  // `model` (the configured tracked body), `rig` and `recording` are borrowed and must outlive the
  // job; `fit_model` is the body fitted when not the tracked one (null: the tracked one).
  // `fps`: the cameras' rate, which spaces the collected frame sets.
  BodyFitJob(const ServerConfig& config, const BodyModel& model, const Rig& rig,
             std::shared_ptr<const BodyModel> fit_model, double fps, RecordingControl& recording);
  ~BodyFitJob();
  BodyFitJob(const BodyFitJob&) = delete;
  BodyFitJob& operator=(const BodyFitJob&) = delete;

  // Pipeline::fitBody: queues a fit for the mask thread, or calls `done` at once with a refusal.
  void request(int frame_sets, bool apply, std::function<void(const FitBodyResult&)> done);
  // The latest body applied by a fit, else the configured one.
  TrackedBody appliedBody() const;

  // Requests are accepted from now on (the mask thread runs).
  void open();
  // Mask thread, once per loop: takes a queued request, and ends a collection that has waited too
  // long for frame sets.
  void poll();
  // Mask thread: the silhouettes of a set handed to the tracker. A fit takes only complete sets
  // (every camera's frame of the same instant): a camera missing from a set leaves its silhouette
  // of an earlier frame, or none yet, and the subject turns between frames.
  void add(const std::vector<SilhouetteMask>& masks, bool complete);
  // Mask thread, as it ends: refuses further requests and ends a collection under way.
  void close();
  // Tracker thread: whether a body was applied since the last call.
  bool takeBodySwitch() { return body_switch_pending_.exchange(false); }
  // Ends a fit under way at its next frame set's search and waits for its thread.
  void stop();

 private:
  struct Collection {
    int frame_sets = 0;
    bool apply = false;
    int every = 1;  // one set kept out of this many handed to the tracker
    int seen = 0;
    std::function<void(const FitBodyResult&)> done;
    std::vector<std::vector<SilhouetteMask>> frames;
    int64_t last_progress_ns = 0;
  };

  const BodyModel& fitModel() const { return fit_model_ ? *fit_model_ : model_; }
  // Mask thread: adds a set's silhouettes (if any) to the collection; once it has them all, starts
  // the fit thread. True when the collection is over (handed on or given up, its `done` called).
  bool collect(Collection& collection, const std::vector<SilhouetteMask>* masks);
  // Fit thread.
  void run(Collection collection);
  // Applies the fitted proportions to the configured body; returns its version.
  uint32_t apply(const BodyProportions& proportions);
  void end(const std::function<void(const FitBodyResult&)>& done, const FitBodyResult& result,
           bool applies);

  const ServerConfig& config_;
  const BodyModel& model_;
  const Rig& rig_;
  const std::shared_ptr<const BodyModel> fit_model_;  // null: the tracked model
  const double fps_;
  RecordingControl& recording_;

  mutable std::mutex body_mutex_;
  TrackedBody applied_body_;
  std::atomic<bool> body_switch_pending_{false};

  // A request, handed from the requester to the mask thread under mutex_.
  std::mutex mutex_;
  std::unique_ptr<Collection> request_;
  bool busy_ = false;                       // requested, collecting or fitting
  bool accepting_ = false;                  // while the mask thread runs
  std::unique_ptr<Collection> collecting_;  // mask thread only

  // Started by the mask thread, joined before the next one starts and by stop(), which sets
  // stop_fit_ first.
  std::thread fit_thread_;
  std::atomic<bool> stop_fit_{false};
};

}  // namespace mocap
