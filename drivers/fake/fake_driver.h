// The fake camera driver, registered as "fake": cameras of a synthetic scene (the default), or of a
// recorded session played back. Lets the whole pipeline run, be tested and be benchmarked without
// cameras.
//
// How a CameraConfig maps:
//   device "scene:<i>"  camera i of the scene's rig; "" or "scene" means camera config.index.
//     Either may end in "?<fault>&<fault>..." to give that camera faults of its own, over the
//     scene's (a daemon's configuration has no other way to set them):
//       drop_rate=<chance>                       each frame lost with this chance
//       stall=<s>@<start s>[/<every s>]          frames stop for s seconds from start (scene time),
//                                                again every `every` seconds if given
//       disconnect=<s>@<start s>[/<every s>]     the same, reported as the camera going and coming
//     e.g. "scene:0?drop_rate=0.01&stall=2@30/45".
//   device "replay:<session dir>:<i>"  camera i of the recorded session at that path.
//   width, height  must equal the rig's (scene) or the session's (replay) size for that camera.
//   fps            scene: must equal FakeSceneOptions::fps; replay: ignored (the recorded pace).
//   pixel_format   "" (the source's), "GREY" or "BGR3"; converted per frame if the source differs.
//   trigger        free-run only. exposure_us, gain_db: ignored.
//   index          copied into Frame::camera.
// Everything else (model, motion, rig, pacing, faults, replay pace and looping) comes from
// FakeDriverOptions: the registry's factory uses the defaults; the daemon and tests construct a
// FakeDriver with their own.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "drivers/camera_driver.h"
#include "drivers/fake/fake_camera.h"
#include "drivers/fake/fake_scene.h"

namespace mocap {

struct FakeDriverOptions {
  FakeSceneOptions scene;
  FakeReplayOptions replay;
};

class FakeDriver final : public Driver {
 public:
  explicit FakeDriver(FakeDriverOptions options = {});
  std::string name() const override { return "fake"; }
  // The scene's cameras ("scene:0", ...), nothing else; empty if the scene cannot be built.
  std::vector<CameraInfo> enumerate() override;
  // The returned camera is a FakeSceneCamera or a FakeReplayCamera. A bad session fails here,
  // naming the file and frame.
  Expected<std::unique_ptr<Camera>> open(const CameraConfig& config) override;

  // The scene every scene camera of this driver shares, built on first use: its groundTruth() is
  // what tests and the daemon measure tracking error against.
  Expected<std::shared_ptr<FakeScene>> scene();

 private:
  Expected<std::unique_ptr<Camera>> openScene(const CameraConfig& config, int rig_camera,
                                              const std::string& faults_query);
  Expected<std::unique_ptr<Camera>> openReplay(const CameraConfig& config, const std::string& session, int camera);

  const FakeDriverOptions options_;
  std::mutex mutex_;
  std::shared_ptr<FakeScene> scene_;
  // Cameras of one session share its reader and start time.
  std::map<std::string, std::weak_ptr<ReplaySource>> replays_;
};

void registerFakeDriver(DriverRegistry& registry);

}  // namespace mocap
