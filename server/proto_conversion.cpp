// Daemon types to wire messages.
#include "server/proto_conversion.h"

namespace mocap {
namespace {

void vec3ToProto(const Eigen::Vector3d& v, v1::Vec3& out) {
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
}

}  // namespace

void poseToProto(const Pose& pose, const BodyModel& model, const std::vector<int>& joints,
                 uint64_t missed_before, v1::Pose& out) {
  out.Clear();
  out.set_frame_sequence(pose.frame_sequence);
  out.set_capture_monotonic_ns(pose.capture_monotonic_ns);
  out.set_capture_wall_ns(pose.capture_wall_ns);
  out.set_publish_monotonic_ns(pose.publish_monotonic_ns);
  v1::StageTimes& stages = *out.mutable_stages();
  stages.set_silhouettes_start_ns(pose.stages.silhouettes_start_ns);
  stages.set_silhouettes_end_ns(pose.stages.silhouettes_end_ns);
  stages.set_track_start_ns(pose.stages.track_start_ns);
  stages.set_track_end_ns(pose.stages.track_end_ns);
  const auto addJoint = [&](int p) {
    v1::JointPosition* joint = out.add_joints();
    joint->set_name(model.points[p].name);
    vec3ToProto(pose.points[p], *joint->mutable_position());
  };
  if (joints.empty()) {
    for (std::size_t p = 0; p < pose.points.size(); ++p) addJoint(static_cast<int>(p));
  } else {
    for (int p : joints) addJoint(p);
  }
  for (const Eigen::Quaterniond& q : pose.orientations) {
    v1::Quaternion* o = out.add_segment_orientations();
    o->set_w(q.w());
    o->set_x(q.x());
    o->set_y(q.y());
    o->set_z(q.z());
  }
  out.mutable_dofs()->Reserve(static_cast<int>(pose.dofs.size()));
  for (Eigen::Index d = 0; d < pose.dofs.size(); ++d) out.add_dofs(pose.dofs[d]);
  out.set_score(pose.score);
  out.set_spread(pose.spread);
  if (pose.reference_error_mm) out.set_reference_error_mm(*pose.reference_error_mm);
  if (pose.silhouette_fit) out.set_silhouette_fit(*pose.silhouette_fit);
  out.set_body_version(pose.body_version);
  out.set_missed_before(missed_before);
}

void skeletonToProto(const BodyModel& model, uint32_t body_version, v1::Skeleton& out) {
  out.Clear();
  out.set_model_name(model.name);
  out.set_body_version(body_version);
  for (const Segment& segment : model.segments) {
    v1::Segment* s = out.add_segments();
    s->set_name(segment.name);
    s->set_parent(segment.parent);
    vec3ToProto(segment.offset, *s->mutable_rest_offset());
    for (int d : segment.dofs) s->add_dofs(d);
  }
  for (const Dof& dof : model.dofs) {
    v1::Dof* d = out.add_dofs();
    d->set_name(dof.name);
    d->set_type(dof.type == DofType::kRotation ? v1::Dof::ROTATION : v1::Dof::TRANSLATION);
    vec3ToProto(dof.axis, *d->mutable_axis());
    d->set_min(dof.min);
    d->set_max(dof.max);
    d->set_segment(dof.segment);
  }
  for (const BodyPoint& point : model.points) {
    v1::Point* p = out.add_points();
    p->set_name(point.name);
    p->set_segment(point.segment);
    vec3ToProto(point.local, *p->mutable_local());
  }
}

void cameraInfoToProto(const OpenedCamera& camera, v1::CameraInfo& out) {
  const CameraInfo& info = camera.info;
  out.set_index(camera.config.index);
  out.set_driver(camera.config.driver);
  out.set_id(info.id.empty() ? camera.config.device : info.id);
  out.set_model(info.model);
  for (const VideoMode& mode : info.modes) {
    v1::VideoMode* m = out.add_modes();
    m->set_width(mode.width);
    m->set_height(mode.height);
    m->set_fps(mode.fps);
    m->set_pixel_format(mode.pixel_format);
  }
  v1::VideoMode* configured = out.mutable_configured();
  configured->set_width(camera.config.width);
  configured->set_height(camera.config.height);
  configured->set_fps(camera.config.fps);
  configured->set_pixel_format(camera.config.pixel_format);
}

void latencyToProto(const LatencySummary& latency, v1::LatencyPercentiles& out) {
  out.set_p50_ms(latency.p50_ms);
  out.set_p90_ms(latency.p90_ms);
  out.set_p99_ms(latency.p99_ms);
  out.set_max_ms(latency.max_ms);
  out.set_samples(static_cast<uint32_t>(latency.samples));
}

void recordingToProto(const RecordingStatus& recording, v1::RecordingState& out) {
  out.set_active(recording.active);
  out.set_path(recording.path);
  out.set_frame_sets(recording.frame_sets);
  out.set_started_wall_ns(recording.started_wall_ns);
}

void cameraStatusToProto(const OpenedCamera& camera, const CameraRuntimeStatus& status,
                         bool pipeline_running, v1::CameraStatus& out) {
  out.set_index(camera.config.index);
  out.set_driver(camera.config.driver);
  out.set_id(camera.info.id.empty() ? camera.config.device : camera.info.id);
  out.set_state(!pipeline_running ? v1::CAMERA_STATE_STOPPED
                : status.streaming ? v1::CAMERA_STATE_STREAMING
                                   : v1::CAMERA_STATE_STALLED);
  out.set_measured_fps(status.measured_fps);
  out.set_frames_received(status.sync.frames_received);
  out.set_silhouettes(status.silhouettes);
  v1::CameraDrops* drops = out.mutable_drops();
  drops->set_lost_by_driver(status.sync.frames_lost_by_driver);
  drops->set_late(status.sync.droppedBy(DropCause::kLate));
  drops->set_overflow(status.sync.droppedBy(DropCause::kOverflow));
  drops->set_unmatched(status.sync.droppedBy(DropCause::kUnmatched));
  drops->set_incomplete_skipped(status.sync.droppedBy(DropCause::kIncompleteSkipped));
  drops->set_superseded(status.sync.droppedBy(DropCause::kSuperseded));
  drops->set_closed(status.sync.droppedBy(DropCause::kClosed));
}

void bodyFitToProto(const FitBodyResult& result, v1::FitBodyResponse& out) {
  out.Clear();
  out.set_body_model_yaml(formatBodyModel(result.body));
  out.set_body_version(result.body_version);
  for (int k = 0; k < BodyProportions::kCount; ++k) {
    v1::BodyProportion* proportion = out.add_proportions();
    proportion->set_name(BodyProportions::name(k));
    proportion->set_factor(result.fit.proportions[k]);
  }
  out.set_scale(result.fit.scale);
  out.set_log_likelihood(result.fit.log_likelihood);
  out.set_evaluations(result.fit.evaluations);
  out.set_frame_sets_used(static_cast<uint32_t>(result.frame_sets_used));
  out.set_fit_seconds(result.fit_seconds);
}

}  // namespace mocap
