// BVH export: the segment tree as a BVH hierarchy, each segment's local transform per frame as
// Euler angles in the hierarchy's channel order.
#include "clients/mocapctl/bvh_export.h"

#include <cmath>
#include <iomanip>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

namespace mocapctl {
namespace {

Eigen::Vector3d toEigen(const mocap::v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }

bool hasPositionChannels(const mocap::v1::Skeleton& skeleton, int s) {
  if (skeleton.segments(s).parent() < 0) return true;
  for (int d : skeleton.segments(s).dofs())
    if (skeleton.dofs(d).type() == mocap::v1::Dof::TRANSLATION) return true;
  return false;
}

// Segment s in its parent's frame: the rest offset, then each DOF in order (as the daemon's
// kinematics composes them).
Eigen::Isometry3d localTransform(const mocap::v1::Skeleton& skeleton, int s,
                                 const std::vector<double>& q) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translate(toEigen(skeleton.segments(s).rest_offset()));
  for (int d : skeleton.segments(s).dofs()) {
    const mocap::v1::Dof& dof = skeleton.dofs(d);
    const Eigen::Vector3d axis = toEigen(dof.axis()).normalized();
    if (dof.type() == mocap::v1::Dof::TRANSLATION) {
      t.translate(q[d] * axis);
    } else {
      t.rotate(Eigen::AngleAxisd(q[d], axis));
    }
  }
  return t;
}

// The point of the segment farthest from its origin: where its End Site goes.
Eigen::Vector3d endSite(const mocap::v1::Skeleton& skeleton, int s) {
  Eigen::Vector3d best = Eigen::Vector3d::Zero();
  for (const mocap::v1::Point& point : skeleton.points()) {
    if (point.segment() == s && toEigen(point.local()).norm() > best.norm()) best = toEigen(point.local());
  }
  return best;
}

void writeOffset(std::ostream& out, const Eigen::Vector3d& v) {
  out << "OFFSET " << v.x() << " " << v.y() << " " << v.z() << "\n";
}

void writeJoint(std::ostream& out, const mocap::v1::Skeleton& skeleton, int s, int depth) {
  const std::string indent(2 * static_cast<std::size_t>(depth), ' ');
  out << indent << (depth == 0 ? "ROOT " : "JOINT ") << skeleton.segments(s).name() << "\n"
      << indent << "{\n"
      << indent << "  ";
  writeOffset(out, toEigen(skeleton.segments(s).rest_offset()));
  out << indent << "  CHANNELS "
      << (hasPositionChannels(skeleton, s) ? "6 Xposition Yposition Zposition " : "3 ")
      << "Zrotation Xrotation Yrotation\n";
  bool has_children = false;
  for (int child = 0; child < skeleton.segments_size(); ++child) {
    if (skeleton.segments(child).parent() != s) continue;
    has_children = true;
    writeJoint(out, skeleton, child, depth + 1);
  }
  if (!has_children) {
    out << indent << "  End Site\n" << indent << "  {\n" << indent << "    ";
    writeOffset(out, endSite(skeleton, s));
    out << indent << "  }\n";
  }
  out << indent << "}\n";
}

// Channel values of segment s and its subtree, in hierarchy order.
void writeMotion(std::ostream& out, const mocap::v1::Skeleton& skeleton, int s,
                 const std::vector<double>& q) {
  const Eigen::Isometry3d local = localTransform(skeleton, s, q);
  if (hasPositionChannels(skeleton, s)) {
    const Eigen::Vector3d p = local.translation();
    out << p.x() << " " << p.y() << " " << p.z() << " ";
  }
  // R = Rz(a) Rx(b) Ry(c): the order of the CHANNELS line.
  const Eigen::Vector3d zxy = local.rotation().eulerAngles(2, 0, 1) * (180.0 / M_PI);
  out << zxy[0] << " " << zxy[1] << " " << zxy[2] << " ";
  for (int child = 0; child < skeleton.segments_size(); ++child)
    if (skeleton.segments(child).parent() == s) writeMotion(out, skeleton, child, q);
}

}  // namespace

void writeBvh(std::ostream& out, const mocap::v1::Skeleton& skeleton,
              const std::vector<std::vector<double>>& frames, double frame_time_s) {
  if (skeleton.segments_size() == 0) throw std::runtime_error("the skeleton has no segments");
  out << std::setprecision(8) << "HIERARCHY\n";
  // BVH has one root: segments without a parent after the first are not expected from the daemon.
  writeJoint(out, skeleton, 0, 0);
  out << "MOTION\nFrames: " << frames.size() << "\nFrame Time: " << frame_time_s << "\n";
  for (const std::vector<double>& q : frames) {
    if (static_cast<int>(q.size()) != skeleton.dofs_size()) {
      throw std::runtime_error("a pose has " + std::to_string(q.size()) + " DOFs, the skeleton " +
                               std::to_string(skeleton.dofs_size()));
    }
    writeMotion(out, skeleton, 0, q);
    out << "\n";
  }
}

}  // namespace mocapctl
