// The daemon's configuration: the YAML file (or the embedded default) turned into typed settings,
// every value checked at start so a bad one is refused with its file, line, field and reason.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "drivers/camera_driver.h"
#include "drivers/record/session_format.h"
#include "server/vmc_target.h"
#include "tracker/filters/filter.h"
#include "tracker/motion/bvh.h"
#include "tracker/search/acquire.h"

namespace mocap {

// Thrown for any unusable configuration; what() is "<file>:<line>: <field>: <reason>".
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class LogLevel { kDebug, kInfo, kWarning, kError };
// "debug", "info", "warning" (or "warn"), "error"; nullopt otherwise.
std::optional<LogLevel> parseLogLevel(const std::string& name);

struct TrackerSettings {
  std::string method = "factored";  // "factored", "condensation" or "annealed"
  int threads = 1;                  // worker threads of the filter (counting the tracker thread)
  // The filter's options, one `tracker:` key each (tracker/filters/filter_options.h): the paper's
  // hand setup unless the tracked body is a person (forPeople).
  FilterOptions filter;
  // "all" tracks every DOF of the body; "gait" only the body model's gait_dofs (paper §8.4: the
  // human's 17 of the lower body and trunk), the others held at the starting pose.
  std::string dofs = "all";
  // Where tracking starts. "auto": live on the fake scene, its true first pose; otherwise the
  // subject found in the silhouettes (tracker/search/acquire.h) when the body's root can be placed
  // (a person), else the neutral pose (the hand). "acquire": always found (a body whose root
  // cannot be placed is refused). "neutral": the body model's neutral pose.
  std::string start = "auto";
  // Loss detection, for a body the tracker can find by itself (AcquiringOptions): lost when the
  // pose's silhouette fit stays under `lost_below` times its recent level for `lost_after` frames;
  // the subject is then found again. 0: never.
  double lost_below = 0;
  int lost_after = 5;
  // Every so many frame sets, the subject is found again and the hypotheses tried against the
  // track (AcquiringOptions::challenge_every); 0: never. Only when the tracker finds the subject
  // itself (`start` above), not from the fake scene's true first pose.
  int challenge_every = AcquiringOptions{}.challenge_every;
  // Hypotheses this far behind the best leave a trial (AcquiringOptions::trial_drop_margin).
  double trial_drop_margin = AcquiringOptions{}.trial_drop_margin;

  // The defaults when the tracked body is a person (body_model: builtin:human, a model file with
  // `kind: person`, or a scene_motion): humanFilterDefaults() at kHumanEvaluations. Keys under
  // `tracker:` override either.
  static TrackerSettings forPeople();
  // Every setting but the thread count (which belongs to the machine, not to the tracking) as the
  // text of its `tracker:` key: what a recorded session stores.
  std::vector<std::pair<std::string, std::string>> keyValues() const;
};

struct SyncSettings {
  std::optional<double> tolerance_ms;  // default: a third of the frame period
  std::optional<double> deadline_ms;   // default: two frame periods
};

// The web view (server/web_view.h): served by the daemon, on loopback unless told otherwise.
struct WebSettings {
  bool enabled = true;
  std::string listen = "127.0.0.1:8080";
};

// Avatar apps the poses are sent to over VMC (server/vmc_sender.h): `vmc: {send_to: [HOST:PORT,
// ...]}`; none: off.
struct VmcSettings {
  std::vector<VmcTarget> send_to;
};

// How sessions are recorded: `recording: {images: lossless|compressed|none, jpeg_quality: N,
// min_free_mb: N}` (docs/recording.md).
struct RecordingSettings {
  ImageMode images = ImageMode::kLossless;
  int jpeg_quality = 90;  // images: compressed, 1-100 (OpenCV's JPEG quality)
  // Free space floor of the recording directory's file system: a recording does not start below
  // it and stops (cleanly, keeping every committed frame set) when it gets there; 0: none.
  // 512 MB leaves the system room for its logs and a few seconds of a lossless recording.
  int min_free_mb = 512;
};

struct ServerConfig {
  std::string source = "<embedded default>";  // where it came from, for messages
  std::vector<CameraConfig> cameras;
  // OpenCV FileStorage rig file; empty: the rig the cameras' driver describes (fake scene).
  std::string calibration_file;
  // Body model YAML, "builtin:hand" or "builtin:human"; empty: the model the cameras' driver
  // describes (the fake scene's hand, or the human with a scene motion).
  std::string body_model;
  // That file as the configuration check read it (null for a built-in, none, or a configuration
  // not parsed from YAML): the server tracks this one rather than reading the file again.
  std::shared_ptr<const BodyModel> body_model_file;
  // Fake scene only: a BVH file (CMU's skeleton) the scene plays, retargeted at the cameras' rate
  // onto the body model fitted to the recorded subject; the tracker tracks that fitted body unless
  // track_subject_body is false.
  std::string scene_motion;
  // The fake scene: seconds the cameras see the empty room before the subject walks in (time to
  // capture the background, as before a real session).
  double scene_empty_seconds = 0;
  // The fake scene: wall-clock seconds per second of the scene, from 1 (real time) to 1000. In slow
  // motion a machine too slow to track the scene live (a sanitizer build) still tracks every frame
  // set; the motion itself is unchanged. The synchronizer's period (and so its default tolerance
  // and deadline) is the frames' spacing on the clock.
  double scene_slow_motion = 1;
  // With a scene_motion: seconds the subject then stands still in the body model's fit_pose, where
  // and facing the way the motion starts, before it moves (time to fit the body: FitBody).
  double scene_fit_pose_seconds = 0;
  // With a scene_motion: false tracks the configured body_model as given (as with a real person,
  // whose body nobody fitted beforehand) while the scene still shows the recorded subject's body.
  bool track_subject_body = true;
  // With a scene_motion: the seed of the simulated person the cameras see in place of the body
  // (`scene_subject_seed`; tracker/sim/subject.h), moving as the body does: a subject whose shape
  // and clothes are not the tracked body's (the product path). The scene's truth is then that
  // person's. Unset: the cameras see the body itself.
  std::optional<uint64_t> scene_subject_seed;
  // With a scene_motion: how its BVH file is read (tracker/motion/bvh.h): its length unit
  // (`scene_motion_units`: auto, m, cm, mm, cmu or inch) and a joint map file for a skeleton whose
  // naming is not built in (`scene_motion_joint_map`, resolved against the configuration's folder).
  BvhLoadOptions scene_motion_load;
  TrackerSettings tracker;
  // The `tracker:` keys the file set itself, as written (a replay applies them over the session's).
  std::vector<std::pair<std::string, std::string>> tracker_keys;
  SyncSettings sync;
  std::string listen = "127.0.0.1:50051";
  std::string recording_directory;  // empty: recording is off
  RecordingSettings recording;
  // Where CaptureBackground saves each camera's background and start-up loads it from; empty:
  // backgrounds last until the daemon stops.
  std::string background_directory;
  // Fake scene only: hand the tracker the scene's true silhouettes (the demo measures tracking)
  // instead of extracting them from the rendered images (false: YAML `silhouettes: extracted`).
  bool true_silhouettes = true;
  // Extracted silhouettes of a camera with no background yet (none captured or loaded; a replayed
  // session that stores none): false (YAML `before_background: wait`) gives the tracker nothing
  // until every camera has one, so no poses; true (`threshold`) thresholds the images, for a lit
  // subject against a dark background.
  bool threshold_before_background = false;
  std::string tls_cert_file;  // both or neither
  std::string tls_key_file;
  // With TLS: PEM certificates of the authorities whose certificates clients must present (mutual
  // TLS); empty: clients are not asked for one (the bearer token authenticates them).
  std::string tls_client_ca_file;
  std::string bearer_token;  // empty: no token required
  WebSettings web;
  VmcSettings vmc;
  LogLevel log_level = LogLevel::kInfo;
  // Replay a recorded session instead of the configured cameras.
  std::string replay_directory;
  bool as_fast_as_possible = false;  // replay: no pacing at the recorded rate
  // Replay: track the silhouettes the session recorded with each frame instead of extracting them
  // from its images again. The same silhouettes (the recorder extracts them as a replay does),
  // without decoding an image: for replays as fast as the tracker goes.
  bool recorded_silhouettes = false;

  bool replay() const { return !replay_directory.empty(); }
};

// The configuration used when mocapd is started without --config: the fake two-camera scene at
// 780x580 and 25 Hz, listening on loopback.
extern const char* const kDefaultConfigYaml;

// Parses and checks a configuration; `source` names it in messages. Relative paths in it are
// resolved against `base_directory` (the config file's directory). Throws ConfigError.
ServerConfig parseConfig(const std::string& yaml_text, const std::string& source,
                         const std::string& base_directory);
ServerConfig loadConfigFile(const std::string& path);

// The tracker settings of a replay: the ones the session stored (`stored`, from its manifest,
// named `source` in errors), with the keys the configuration set itself on top and the
// configuration's thread count. A key the session did not store (it was recorded before the key
// existed) takes the plain default, which leaves the later option off, not the value for people.
// Throws ConfigError naming the source and the key.
TrackerSettings replayTrackerSettings(
    const ServerConfig& config, const std::vector<std::pair<std::string, std::string>>& stored,
    const std::string& source);

}  // namespace mocap
