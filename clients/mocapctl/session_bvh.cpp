// A recorded session's true poses as a BVH clip, and a body model as a wire skeleton.
#include "clients/mocapctl/session_bvh.h"

#include <optional>
#include <stdexcept>

namespace mocapctl {
namespace {

void setVec3(const Eigen::Vector3d& v, mocap::v1::Vec3& out) {
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
}

// The truth of a set is keyed by the camera_sequence of its first frame.
const Eigen::VectorXd* truthOf(const mocap::SessionReader& session, const mocap::SessionSet& set) {
  for (const std::optional<mocap::IndexRecord>& frame : set.frames)
    if (frame) return session.truth(frame->camera_sequence);
  return nullptr;
}

}  // namespace

mocap::v1::Skeleton skeletonOf(const mocap::BodyModel& model) {
  mocap::v1::Skeleton out;
  out.set_model_name(model.name);
  for (const mocap::Segment& segment : model.segments) {
    mocap::v1::Segment* s = out.add_segments();
    s->set_name(segment.name);
    s->set_parent(segment.parent);
    setVec3(segment.offset, *s->mutable_rest_offset());
    for (int d : segment.dofs) s->add_dofs(d);
  }
  for (const mocap::Dof& dof : model.dofs) {
    mocap::v1::Dof* d = out.add_dofs();
    d->set_name(dof.name);
    d->set_type(dof.type == mocap::DofType::kRotation ? mocap::v1::Dof::ROTATION
                                                      : mocap::v1::Dof::TRANSLATION);
    setVec3(dof.axis, *d->mutable_axis());
    d->set_min(dof.min);
    d->set_max(dof.max);
    d->set_segment(dof.segment);
  }
  for (const mocap::BodyPoint& point : model.points) {
    mocap::v1::Point* p = out.add_points();
    p->set_name(point.name);
    p->set_segment(point.segment);
    setVec3(point.local, *p->mutable_local());
  }
  return out;
}

BvhClip truthClip(const mocap::SessionReader& session) {
  const std::string name = session.path().string();
  if (!session.hasTruth()) {
    throw std::runtime_error(name +
                             ": the session stores frames but no true poses (truth.csv: only "
                             "sources that know the truth, the fake scene, write it), and no "
                             "session stores the tracked poses: replay it (mocapd --replay " +
                             name + ") and run mocapctl bvh --seconds N against the daemon");
  }
  const mocap::BodyModel* body = session.truthBodyModel();
  if (!body) throw std::runtime_error(name + ": the session stores true poses but no body model");

  BvhClip clip;
  clip.skeleton = skeletonOf(*body);
  int64_t first_ns = 0, last_ns = 0;
  int pending_holds = 0;  // sets without truth since the last one with it
  for (const mocap::SessionSet& set : session.sets()) {
    const Eigen::VectorXd* truth = truthOf(session, set);
    if (!truth) {
      if (!clip.frames.empty()) ++pending_holds;
      continue;
    }
    for (; pending_holds > 0; --pending_holds, ++clip.held_sets)
      clip.frames.push_back(clip.frames.back());
    if (clip.frames.empty()) first_ns = set.timestamp_ns;
    last_ns = set.timestamp_ns;
    clip.frames.emplace_back(truth->data(), truth->data() + truth->size());
  }
  if (clip.frames.empty())
    throw std::runtime_error(name + ": truth.csv has no line for any committed frame set");
  const double fps = session.cameras().empty() ? 0 : session.cameras().front().fps;
  clip.frame_time_s = clip.frames.size() > 1 ? static_cast<double>(last_ns - first_ns) / 1e9 /
                                                   static_cast<double>(clip.frames.size() - 1)
                                             : (fps > 0 ? 1 / fps : 0.04);
  return clip;
}

}  // namespace mocapctl
