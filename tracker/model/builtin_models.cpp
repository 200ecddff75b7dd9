// The built-in body models and the hand's rig.
#include "tracker/model/builtin_models.h"

#include <cmath>

#include "tracker/hand_model_yaml.h"
#include "tracker/human_model_yaml.h"

namespace mocap {

BodyModel builtinHandModel() { return parseBodyModel(kHandModelYaml, "built-in hand.yaml"); }

BodyModel builtinHumanModel() { return parseBodyModel(kHumanModelYaml, "built-in human.yaml"); }

Rig handRig(int cameras, int width, int height) {
  // The hand spans about 0.2 m around this point; 0.55 m away, it fills most of the image height.
  const Eigen::Vector3d target(0.0, 0.0, 0.05);
  const double distance = 0.55;
  const double focal = 1200.0 * height / 580.0;
  Rig rig;
  for (int i = 0; i < cameras; ++i) {
    // Azimuth 0 looks at the palm (from -Y); the arc spans +-70 degrees; elevations alternate.
    const double azimuth = cameras == 1 ? 0.0 : (-70.0 + 140.0 * i / (cameras - 1)) * M_PI / 180;
    const double elevation = (i % 2 ? 5.0 : 25.0) * M_PI / 180;
    const Eigen::Vector3d eye =
        target + distance * Eigen::Vector3d(std::sin(azimuth) * std::cos(elevation),
                                            -std::cos(azimuth) * std::cos(elevation),
                                            std::sin(elevation));
    rig.push_back(CameraModel::lookAt("cam" + std::to_string(i), eye, target,
                                      Eigen::Vector3d::UnitZ(), width, height, focal));
  }
  return rig;
}

}  // namespace mocap
