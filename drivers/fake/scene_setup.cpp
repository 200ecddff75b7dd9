// The fake scene as the daemon sets it up: the subject from a BVH file, the scene and its cameras.
#include "drivers/fake/scene_setup.h"

#include <cmath>

#include "drivers/fake/fake_driver.h"
#include "tracker/motion/retarget.h"

namespace mocap {
namespace {

FakeDriverOptions fakeDriverOptions(const FakeSceneSetupOptions& setup) {
  FakeDriverOptions options;
  const CameraConfig& first = setup.cameras.front();
  options.scene.cameras = static_cast<int>(setup.cameras.size());
  options.scene.width = first.width;
  options.scene.height = first.height;
  options.scene.fps = first.fps;
  options.scene.gray = first.pixel_format == "GREY";
  options.scene.seed = setup.seed;
  options.scene.slow_motion = setup.slow_motion;
  if (setup.subject) options.scene.model = std::make_shared<const BodyModel>(*setup.subject);
  if (setup.rig) options.scene.rig = *setup.rig;
  options.scene.motion = setup.motion;
  options.scene.empty_frames = static_cast<uint64_t>(std::llround(setup.empty_seconds * first.fps));
  options.scene.fit_pose_frames =
      static_cast<uint64_t>(std::llround(setup.fit_pose_seconds * first.fps));
  // A second to step out of the fit pose into the motion, as a person would.
  if (options.scene.fit_pose_frames > 0)
    options.scene.step_out_frames = static_cast<uint64_t>(std::llround(first.fps));
  if (setup.subject_seed) options.scene.subject = drawSubjectParams(*setup.subject_seed);
  return options;
}

}  // namespace

SceneSubject loadSceneSubject(const std::string& bvh_file, const BodyModel& model, double fps,
                              const BvhLoadOptions& load) {
  const Bvh bvh = loadBvh(bvh_file, load);
  auto fitted = std::make_shared<const BodyModel>(fitModelToBvh(model, bvh.skeleton));
  auto motion =
      std::make_shared<const Motion>(retargetBvh(*fitted, bvh.skeleton, bvh.motion, fps).motion);
  return {std::move(fitted), std::move(motion)};
}

Expected<FakeSceneSetup> setUpFakeScene(const FakeSceneSetupOptions& options) {
  FakeDriver driver(fakeDriverOptions(options));
  Expected<std::shared_ptr<FakeScene>> scene = driver.scene();
  if (!scene.ok()) return Status::Error("fake scene: " + scene.error());
  FakeSceneSetup setup;
  setup.scene = scene.value();
  for (const CameraConfig& camera : options.cameras) {
    Expected<std::unique_ptr<Camera>> opened = driver.open(camera);
    if (!opened.ok()) {
      return Status::Error("cameras[" + std::to_string(camera.index) + "] (fake " + camera.device +
                           "): " + opened.error());
    }
    setup.cameras.push_back(std::move(opened.value()));
  }
  return setup;
}

std::vector<std::shared_ptr<const BackgroundModel>> FakeSceneSetup::emptyBackgrounds() const {
  std::vector<std::shared_ptr<const BackgroundModel>> backgrounds;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    auto empty = std::make_shared<BackgroundModel>();
    scene->background(static_cast<int>(c)).convertTo(empty->mean, CV_32F);
    empty->stddev = cv::Mat(empty->mean.size(), empty->mean.type(),
                            cv::Scalar::all(scene->options().noise_sigma));
    backgrounds.push_back(std::move(empty));
  }
  return backgrounds;
}

}  // namespace mocap
