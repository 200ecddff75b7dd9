// The background manager: each camera's silhouette source and the empty-scene backgrounds behind
// them. It learns a background from live frames (CaptureBackground), judges it (a share of the
// image that changed during the capture, or from the background it replaces, is warned of), saves
// it to and loads it from background_directory, and in a replay installs the session's recorded
// backgrounds as their frames come. A camera without a background is thresholded or not tracked
// (before_background); with the fake scene's truth, its source is the truth whatever the
// background.
//
// Threads: capture(), backgroundFile(), sources(), warnings() from any thread; initialize() from
// the pipeline's constructor; open() from the pipeline's start(); poll(), silhouette() and close()
// from the mask thread; joinSaver() from the pipeline's stop() and destructor. Files are written on
// a saver thread of its own, so the mask thread never waits on the disk.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "drivers/record/session_reader.h"
#include "server/config.h"
#include "server/opened_camera.h"
#include "server/silhouette_source.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/vision/background_model.h"

namespace mocap {

class RecordingControl;

// Why a background capture failed, so the service can pick the gRPC code.
// kNotSaved: learned and in use, but a file of background_directory could not be written.
enum class BackgroundError { kNone, kReplay, kBusy, kStalled, kStopped, kUnusable, kNotSaved };
struct BackgroundResult {
  BackgroundError error = BackgroundError::kNone;
  std::string message;
  int frames_used = 0;  // per camera
  // Learned and in use, but doubtful: a camera whose image changed during the capture, or differs
  // from the background it replaced.
  std::vector<std::string> warnings;
};

class BackgroundManager {
 public:
  // The configuration, cameras and recording are borrowed and must outlive it. `replay`: the
  // session replayed, whose backgrounds are installed (null live). `ground_truth`: the scene's
  // true silhouettes, used instead of any background (null: none).
  BackgroundManager(const ServerConfig& config, const std::vector<OpenedCamera>& cameras,
                    std::shared_ptr<const SessionReader> replay,
                    GroundTruthSilhouettes ground_truth, RecordingControl& recording);
  ~BackgroundManager();
  BackgroundManager(const BackgroundManager&) = delete;
  BackgroundManager& operator=(const BackgroundManager&) = delete;

  // Live, loads what background_directory holds for each camera: a file that cannot be used is a
  // warning and that camera is without a background. Throws std::invalid_argument if two cameras
  // would share a background file. In a replay of a session that stores no background, says what
  // becomes of its images.
  void initialize();
  // See Pipeline::backgroundFile.
  std::string backgroundFile(std::size_t camera) const;

  // See Pipeline::captureBackground.
  void capture(int frames, std::function<void(const BackgroundResult&)> done);

  // Captures are accepted from now on (the mask thread runs).
  void open();
  // Mask thread, once per loop: takes a requested capture, and installs it once every camera has
  // its frames or gives up when none came for too long.
  void poll();
  // Mask thread: feeds camera's image to a capture under way and updates `silhouette` from it.
  // False when the camera has no silhouettes (no background yet, and not thresholded).
  bool silhouette(std::size_t camera, const cv::Mat& image, uint64_t frame_sequence,
                  SilhouetteMask& silhouette);
  // Mask thread, as it ends: refuses further captures and ends one under way.
  void close();
  // Waits for the saver thread.
  void joinSaver();

  // Per camera, where its silhouettes come from: "ground truth", "threshold" (with the reason when
  // a saved background was refused), "background captured" or "background loaded from <file>".
  std::vector<std::string> sources() const;
  // Saved backgrounds refused or ignored at start-up, one line each naming the file.
  std::vector<std::string> warnings() const;

 private:
  struct Capture {
    int frames = 0;
    std::function<void(const BackgroundResult&)> done;
    std::vector<BackgroundLearner> learners;  // per camera
    int64_t last_progress_ns = 0;
  };

  // Mask thread: feeds a camera's frame to the capture under way.
  static void learn(Capture& capture, std::size_t camera, const cv::Mat& image);
  // Mask thread: installs the learnt backgrounds once every camera has its frames, or gives up when
  // none came for too long. True when the capture is over (its `done` called, or handed to the
  // saver).
  bool finish(Capture& capture);
  // Mask thread: the learnt backgrounds' warnings (added to `learned`) and log line.
  void judge(const std::vector<std::shared_ptr<const BackgroundModel>>& models,
             const std::vector<std::shared_ptr<const BackgroundModel>>& replaced,
             BackgroundResult& learned) const;
  void endCapture(const std::function<void(const BackgroundResult&)>& done,
                  const BackgroundResult& result);
  // Mask thread (or initialize()): camera's silhouettes come from `background` from its next frame
  // on (null: without one), and an open recording notes it.
  void useBackground(std::size_t camera, std::shared_ptr<const BackgroundModel> background,
                     std::unique_ptr<SilhouetteSource> extracted = nullptr);
  // Mask thread, replay: installs the session's recorded backgrounds due by camera's `frame`.
  void replayBackgrounds(std::size_t camera, uint64_t frame_sequence);
  // Saver thread: writes the captured models, then ends the capture with `learned` (its error
  // set if a file could not be written).
  void save(std::vector<std::shared_ptr<const BackgroundModel>> models, BackgroundResult learned,
            std::function<void(const BackgroundResult&)> done);
  // initialize(): the saved backgrounds, and a warning for each file no camera claims.
  void loadSaved();
  // Camera's saved background at `path`, if it fits the camera; else a warning.
  void loadSaved(std::size_t camera, const std::string& path);
  // The source of a camera without a background (config's before_background): thresholded, or
  // none.
  std::unique_ptr<SilhouetteSource> withoutBackgroundSource() const;
  // The source status of a camera without a background, and why.
  std::string withoutBackground(const std::string& why) const;
  // What becomes of such a camera's images, for messages: "thresholded" or "not tracked".
  const char* withoutBackgroundIs() const;
  // What sources() reports for camera; ignored when the scene gives the truth.
  void setSourceStatus(std::size_t camera, std::string status);
  void warn(const std::string& warning);

  const ServerConfig& config_;
  const std::vector<OpenedCamera>& cameras_;
  const std::shared_ptr<const SessionReader> replay_;
  const bool true_silhouettes_;
  RecordingControl& recording_;

  // Mask thread only (or the constructor's): per camera, its silhouette source (null: none); in
  // replay, the index of the first of the session's backgrounds() not installed yet.
  std::vector<std::unique_ptr<SilhouetteSource>> sources_;
  std::vector<std::size_t> next_replayed_backgrounds_;
  std::unique_ptr<Capture> capturing_;

  // A capture, handed from the requester to the mask thread under mutex_.
  std::mutex mutex_;
  std::unique_ptr<Capture> request_;
  bool busy_ = false;       // requested or under way
  bool accepting_ = false;  // while the mask thread runs

  // Saves a capture's backgrounds; joined before the next one starts and by joinSaver().
  std::thread save_thread_;

  // Read by sources() and warnings().
  mutable std::mutex status_mutex_;
  std::vector<std::string> source_statuses_;
  std::vector<std::string> warnings_;
};

}  // namespace mocap
