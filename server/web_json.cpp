// The web view's JSON documents.
#include "server/web_json.h"

#include <nlohmann/json.hpp>

namespace mocap {
namespace {

using nlohmann::json;

json vector3(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

// A floor extent that holds every camera and the origin, so the 3D view frames the rig.
double floorHalfSize(const Rig& rig) {
  double half = 1.0;
  for (const CameraModel& camera : rig)
    half = std::max({half, std::abs(camera.center().x()), std::abs(camera.center().y())});
  return half;
}

}  // namespace

std::vector<std::pair<int, int>> skeletonLines(const BodyModel& model) {
  std::vector<int> first_point(model.segments.size(), -1);
  std::vector<std::pair<int, int>> lines;
  std::vector<int> last_point(model.segments.size(), -1);
  for (std::size_t p = 0; p < model.points.size(); ++p) {
    const int segment = model.points[p].segment;
    if (segment < 0 || segment >= static_cast<int>(model.segments.size())) continue;
    if (last_point[segment] >= 0) lines.emplace_back(last_point[segment], static_cast<int>(p));
    if (first_point[segment] < 0) first_point[segment] = static_cast<int>(p);
    last_point[segment] = static_cast<int>(p);
  }
  // Parents precede their children, so an ancestor's inherited point is known when a child asks.
  std::vector<int> anchor(model.segments.size(), -1);
  for (std::size_t s = 0; s < model.segments.size(); ++s) {
    const int parent = model.segments[s].parent;
    const int parent_anchor = parent >= 0 ? anchor[parent] : -1;
    anchor[s] = first_point[s] >= 0 ? first_point[s] : parent_anchor;
    if (first_point[s] >= 0 && parent_anchor >= 0 && parent_anchor != first_point[s])
      lines.emplace_back(parent_anchor, first_point[s]);
  }
  return lines;
}

std::string sceneJson(const Rig& rig, const std::vector<OpenedCamera>& cameras) {
  json scene;
  scene["floor_half_size"] = floorHalfSize(rig);
  json list = json::array();
  for (std::size_t c = 0; c < rig.size(); ++c) {
    const CameraModel& camera = rig[c];
    json corners = json::array();
    for (const Eigen::Vector2d& pixel :
         {Eigen::Vector2d(0, 0), Eigen::Vector2d(camera.width - 1, 0),
          Eigen::Vector2d(camera.width - 1, camera.height - 1),
          Eigen::Vector2d(0, camera.height - 1)})
      corners.push_back(vector3(camera.backProject(pixel)));
    const std::string driver = c < cameras.size() ? cameras[c].config.driver : "";
    list.push_back({{"index", c},
                    {"name", camera.name},
                    {"driver", driver},
                    {"width", camera.width},
                    {"height", camera.height},
                    {"center", vector3(camera.center())},
                    {"corner_rays", corners}});
  }
  scene["cameras"] = list;
  return scene.dump();
}

std::string statusJson(const ServerConfig& config, const PipelineStatus& status,
                       const std::vector<OpenedCamera>& cameras, std::size_t grpc_subscribers,
                       std::size_t web_clients) {
  json out;
  out["mode"] = config.replay() ? "replay" : "live";
  out["running"] = status.running;
  out["token_required"] = !config.bearer_token.empty();
  out["tracker_method"] = config.tracker.method;
  out["tracker_fps"] = status.tracker_fps;
  out["poses_published"] = status.poses_published;
  out["frame_sets_skipped"] = status.frame_sets_skipped;
  out["evaluations_per_frame"] = status.evaluations_per_frame;
  out["refinements_cut"] = status.refinements_cut;
  out["tracking"] = status.tracking;
  out["search_failure"] = status.search_failure;
  out["acquisitions"] = status.acquisitions;
  out["losses"] = status.losses;
  out["latency_ms"] = {{"p50", status.latency.p50_ms},
                       {"p90", status.latency.p90_ms},
                       {"p99", status.latency.p99_ms},
                       {"max", status.latency.max_ms},
                       {"samples", status.latency.samples}};
  json stages = json::array();
  for (const auto& [stage, latency] : status.stage_latency)
    stages.push_back({{"stage", stage}, {"p50", latency.p50_ms}, {"p99", latency.p99_ms}});
  out["stage_latency_ms"] = std::move(stages);
  out["recording"] = {{"active", status.recording.active},
                      {"path", status.recording.path},
                      {"frame_sets", status.recording.frame_sets}};
  out["subscribers"] = {{"grpc", grpc_subscribers}, {"web", web_clients}};
  out["background_warnings"] = status.background_warnings;
  json list = json::array();
  for (std::size_t c = 0; c < status.cameras.size(); ++c) {
    const CameraRuntimeStatus& camera = status.cameras[c];
    list.push_back({{"index", c},
                    {"driver", c < cameras.size() ? cameras[c].config.driver : ""},
                    {"device", c < cameras.size() ? cameras[c].config.device : ""},
                    {"fps", camera.measured_fps},
                    {"streaming", camera.streaming},
                    {"frames_received", camera.sync.frames_received},
                    {"dropped", camera.sync.droppedTotal()},
                    {"lost_by_driver", camera.sync.frames_lost_by_driver},
                    {"sets_missed", camera.sync.sets_missed},
                    {"silhouettes", camera.silhouettes}});
  }
  out["cameras"] = list;
  return out.dump();
}

std::string poseJson(const Pose& pose, const TrackedBody& body, const Rig& rig) {
  json out;
  out["frame_sequence"] = pose.frame_sequence;
  out["capture_monotonic_ns"] = pose.capture_monotonic_ns;
  out["publish_monotonic_ns"] = pose.publish_monotonic_ns;
  out["body_version"] = pose.body_version;
  out["score"] = pose.score;
  out["silhouette_fit"] = pose.silhouette_fit ? json(*pose.silhouette_fit) : json();
  out["reference_error_mm"] = pose.reference_error_mm ? json(*pose.reference_error_mm) : json();
  json points = json::array();
  for (const Eigen::Vector3d& point : pose.points) points.push_back(vector3(point));
  out["points"] = points;
  json lines = json::array();
  // A pose of another body version than the one held now has other points: no lines then.
  if (body.model && body.version == pose.body_version &&
      body.model->points.size() == pose.points.size())
    for (const auto& [a, b] : skeletonLines(*body.model)) lines.push_back({a, b});
  out["lines"] = lines;
  json projected = json::array();
  for (const CameraModel& camera : rig) {
    json pixels = json::array();
    for (const Eigen::Vector3d& point : pose.points) {
      Eigen::Vector2d pixel;
      if (camera.project(point, pixel))
        pixels.push_back({std::round(pixel.x() * 10) / 10, std::round(pixel.y() * 10) / 10});
      else
        pixels.push_back(nullptr);
    }
    projected.push_back(pixels);
  }
  out["projected"] = projected;
  return out.dump();
}

}  // namespace mocap
