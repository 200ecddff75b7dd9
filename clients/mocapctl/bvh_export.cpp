// BVH export: the segment tree as a BVH hierarchy, each segment's local transform per frame as
// Euler angles in the hierarchy's channel order, all of it turned into the file's axes and unit.
#include "clients/mocapctl/bvh_export.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

namespace mocapctl {
namespace {

using mocap::v1::Skeleton;

Eigen::Vector3d toEigen(const mocap::v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }

// The daemon's world frame to the file's: its axes and its unit. A length or a rotation of the
// skeleton is expressed in the file by turning it into the file's axes (a change of basis, so the
// hierarchy composes in the file exactly as in the daemon).
struct FileFrame {
  Eigen::Matrix3d from_world = Eigen::Matrix3d::Identity();
  double units_per_metre = 1;

  explicit FileFrame(const BvhExportOptions& options) : units_per_metre(options.units_per_metre) {
    // Y up: (x, y, z) -> (x, z, -y), a quarter turn about X.
    if (options.y_up) from_world << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  }
  Eigen::Vector3d length(const Eigen::Vector3d& v) const {
    return units_per_metre * (from_world * v);
  }
  Eigen::Matrix3d rotation(const Eigen::Matrix3d& r) const {
    return from_world * r * from_world.transpose();
  }
};

bool isRoot(const Skeleton& skeleton, int s) { return skeleton.segments(s).parent() < 0; }

bool hasPositionChannels(const Skeleton& skeleton, int s) {
  if (isRoot(skeleton, s)) return true;
  for (int d : skeleton.segments(s).dofs())
    if (skeleton.dofs(d).type() == mocap::v1::Dof::TRANSLATION) return true;
  return false;
}

// Segment s in its parent's frame: the rest offset, then each DOF in order (as the daemon's
// kinematics composes them). For the root, its world transform.
Eigen::Isometry3d localTransform(const Skeleton& skeleton, int s, const std::vector<double>& q) {
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

// The BVH OFFSET of segment s: zero for the root, whose position channels carry its whole world
// position (so readers that add channels to the offset and readers that replace it agree).
Eigen::Vector3d bvhOffset(const Skeleton& skeleton, int s) {
  return isRoot(skeleton, s) ? Eigen::Vector3d::Zero()
                             : toEigen(skeleton.segments(s).rest_offset());
}

// The point of the segment farthest from its origin: where its End Site goes.
Eigen::Vector3d endSite(const Skeleton& skeleton, int s) {
  Eigen::Vector3d best = Eigen::Vector3d::Zero();
  for (const mocap::v1::Point& point : skeleton.points()) {
    if (point.segment() == s && toEigen(point.local()).norm() > best.norm())
      best = toEigen(point.local());
  }
  return best;
}

void writeOffset(std::ostream& out, const Eigen::Vector3d& v) {
  out << "OFFSET " << v.x() << " " << v.y() << " " << v.z() << "\n";
}

void writeJoint(std::ostream& out, const Skeleton& skeleton, const FileFrame& file, int s,
                int depth) {
  const std::string indent(2 * static_cast<std::size_t>(depth), ' ');
  out << indent << (depth == 0 ? "ROOT " : "JOINT ") << skeleton.segments(s).name() << "\n"
      << indent << "{\n"
      << indent << "  ";
  writeOffset(out, file.length(bvhOffset(skeleton, s)));
  out << indent << "  CHANNELS "
      << (hasPositionChannels(skeleton, s) ? "6 Xposition Yposition Zposition " : "3 ")
      << "Zrotation Xrotation Yrotation\n";
  bool has_children = false;
  for (int child = 0; child < skeleton.segments_size(); ++child) {
    if (skeleton.segments(child).parent() != s) continue;
    has_children = true;
    writeJoint(out, skeleton, file, child, depth + 1);
  }
  if (!has_children) {
    out << indent << "  End Site\n" << indent << "  {\n" << indent << "    ";
    writeOffset(out, file.length(endSite(skeleton, s)));
    out << indent << "  }\n";
  }
  out << indent << "}\n";
}

// The segments in the hierarchy's depth-first order: the order of a motion line's channels.
void appendDepthFirst(const Skeleton& skeleton, int s, std::vector<int>& order) {
  order.push_back(s);
  for (int child = 0; child < skeleton.segments_size(); ++child)
    if (skeleton.segments(child).parent() == s) appendDepthFirst(skeleton, child, order);
}

double nearestTurn(double angle, double previous) {
  return angle - 2 * M_PI * std::round((angle - previous) / (2 * M_PI));
}

// Angles (a, b, c) with R = Rz(a) Rx(b) Ry(c), the CHANNELS order, in radians. Of the two
// solutions (and their whole turns) the one nearest `previous` is taken, so a joint's curves stay
// continuous for an animation tool's interpolation; without a previous frame, |b| <= 90 degrees.
Eigen::Vector3d zxyAngles(const Eigen::Matrix3d& r, const Eigen::Vector3d* previous) {
  const double sin_b = std::clamp(r(2, 1), -1.0, 1.0);
  const double b = std::asin(sin_b);
  Eigen::Vector3d first;
  if (std::abs(sin_b) < 1 - 1e-12) {
    first = {std::atan2(-r(0, 1), r(1, 1)), b, std::atan2(-r(2, 0), r(2, 2))};
  } else {  // gimbal lock: only a + c (or a - c) is defined; c = 0
    first = {std::atan2(r(1, 0), r(0, 0)), b, 0};
  }
  if (!previous) return first;
  const Eigen::Vector3d second(first[0] + M_PI, M_PI - first[1], first[2] + M_PI);
  Eigen::Vector3d best;
  double best_distance = INFINITY;
  for (const Eigen::Vector3d& candidate : {first, second}) {
    Eigen::Vector3d unwrapped;
    for (int i = 0; i < 3; ++i) unwrapped[i] = nearestTurn(candidate[i], (*previous)[i]);
    const double distance = (unwrapped - *previous).squaredNorm();
    if (distance < best_distance) best_distance = distance, best = unwrapped;
  }
  return best;
}

}  // namespace

void writeBvh(std::ostream& out, const Skeleton& skeleton,
              const std::vector<std::vector<double>>& frames, double frame_time_s,
              const BvhExportOptions& options) {
  if (skeleton.segments_size() == 0) throw std::runtime_error("the skeleton has no segments");
  const FileFrame file(options);
  out << std::setprecision(8) << "HIERARCHY\n";
  // BVH has one root: segments without a parent after the first are not expected from the daemon.
  writeJoint(out, skeleton, file, 0, 0);
  out << "MOTION\nFrames: " << frames.size() << "\nFrame Time: " << frame_time_s << "\n";
  std::vector<int> order;
  appendDepthFirst(skeleton, 0, order);
  std::vector<Eigen::Vector3d> previous_angles(static_cast<std::size_t>(skeleton.segments_size()));
  bool first_frame = true;
  for (const std::vector<double>& q : frames) {
    if (static_cast<int>(q.size()) != skeleton.dofs_size()) {
      throw std::runtime_error("a pose has " + std::to_string(q.size()) + " DOFs, the skeleton " +
                               std::to_string(skeleton.dofs_size()));
    }
    for (int s : order) {
      const Eigen::Isometry3d local = localTransform(skeleton, s, q);
      if (hasPositionChannels(skeleton, s)) {
        const Eigen::Vector3d p = file.length(local.translation() - bvhOffset(skeleton, s));
        out << p.x() << " " << p.y() << " " << p.z() << " ";
      }
      Eigen::Vector3d& angles = previous_angles[static_cast<std::size_t>(s)];
      angles = zxyAngles(file.rotation(local.rotation()), first_frame ? nullptr : &angles);
      const Eigen::Vector3d degrees = angles * (180.0 / M_PI);
      out << degrees[0] << " " << degrees[1] << " " << degrees[2] << " ";
    }
    out << "\n";
    first_frame = false;
  }
}

}  // namespace mocapctl
