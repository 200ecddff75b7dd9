// The fake scene as the daemon sets it up: a subject moving along a recorded BVH motion (the body
// fitted to the recorded person, the motion retargeted onto it), the scene built from the camera
// list, its cameras opened, and what the scene knows that real cameras do not (its empty room).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drivers/camera_driver.h"
#include "drivers/fake/fake_scene.h"
#include "drivers/status.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/motion.h"
#include "tracker/vision/background_model.h"

namespace mocap {

// A subject who moves as a recorded person did.
struct SceneSubject {
  std::shared_ptr<const BodyModel> body;  // `model` fitted to the recording's skeleton
  std::shared_ptr<const Motion> motion;   // the recording retargeted onto `body`, at the fps
};

// Loads the BVH file (its units and joint map as `load` says), fits `model` to its skeleton
// (docs/human.md) and retargets its motion onto the fitted body at `fps`. Throws std::exception
// with the loader's message.
SceneSubject loadSceneSubject(const std::string& bvh_file, const BodyModel& model, double fps,
                              const BvhLoadOptions& load = {});

struct FakeSceneSetupOptions {
  // Every camera of the scene, all of driver "fake"; the first one's size, rate and pixel format
  // are the scene's.
  std::vector<CameraConfig> cameras;
  uint64_t seed = 1;
  double empty_seconds = 0;  // FakeSceneOptions::empty_frames, in seconds
  // FakeSceneOptions::fit_pose_frames, in seconds; then 1 s of step_out_frames.
  double fit_pose_seconds = 0;
  double slow_motion = 1;                // FakeSceneOptions::slow_motion
  const BodyModel* subject = nullptr;    // null: the scene's default body
  const Rig* rig = nullptr;              // null: the scene's default rig
  std::shared_ptr<const Motion> motion;  // null: the scene's generated motion
  // Set: the cameras see the simulated person drawSubjectParams(seed) (tracker/sim/subject.h)
  // moving as the body does, not the body itself (FakeSceneOptions::subject).
  std::optional<uint64_t> subject_seed;
};

struct FakeSceneSetup {
  std::shared_ptr<FakeScene> scene;
  std::vector<std::unique_ptr<Camera>> cameras;  // opened, in the order of the options' cameras

  // Per camera, the empty room as a background learnt of it would be: the scene's background,
  // its sensor noise as the deviation.
  std::vector<std::shared_ptr<const BackgroundModel>> emptyBackgrounds() const;
};

// Builds the scene and opens its cameras. The error names the scene ("fake scene: ...") or the
// camera ("cameras[<index>] (fake <device>): ...") at fault.
Expected<FakeSceneSetup> setUpFakeScene(const FakeSceneSetupOptions& options);

}  // namespace mocap
