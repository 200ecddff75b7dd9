// The body models compiled into mocapd (tracker/models/*.yaml) and the virtual camera rig the hand
// is seen by, shared by the experiments, the fake camera driver and the daemon's defaults.
#pragma once

#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

// The 15-DOF hand of the paper's simulation (§7): tracker/models/hand.yaml.
BodyModel builtinHandModel();

// The 31-DOF human body (§8): tracker/models/human.yaml.
BodyModel builtinHumanModel();

// `cameras` virtual cameras spread over an arc in front of the palm, looking at the hand.
Rig handRig(int cameras, int width = 780, int height = 580);

}  // namespace mocap
