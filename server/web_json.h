// The web view's JSON documents: the scene (cameras, frusta, skeleton lines), the status and each
// pose with its joints projected into every camera. Built on the web server's threads from
// snapshots, never on the tracker's.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "server/config.h"
#include "server/opened_camera.h"
#include "server/pipeline.h"
#include "server/pose.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

// The lines drawn between a body's points (indices into BodyModel::points): the points of a
// segment in order, and each segment's first point to its parent's (or the nearest ancestor with
// a point).
std::vector<std::pair<int, int>> skeletonLines(const BodyModel& model);

// The rig for the 3D view and the overlays: per camera its name, size, centre and the world
// directions of its image corners (the frustum), and the floor's extent.
std::string sceneJson(const Rig& rig, const std::vector<OpenedCamera>& cameras);

// The pipeline's status as the page shows it.
std::string statusJson(const ServerConfig& config, const PipelineStatus& status,
                       const std::vector<OpenedCamera>& cameras, std::size_t grpc_subscribers,
                       std::size_t web_clients);

// One pose: world points, the skeleton's lines, and per camera the points projected with the
// tracker's own camera model (distortion included; null where behind the camera).
std::string poseJson(const Pose& pose, const TrackedBody& body, const Rig& rig);

}  // namespace mocap
