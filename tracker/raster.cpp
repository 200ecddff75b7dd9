// Shape outlines, their convex hull in the image, and scan conversion into row spans.
#include "tracker/raster.h"

#include <algorithm>
#include <cmath>

namespace mocap {
namespace {

// ceil for 0 <= x < 2^31 without a libm call (baseline x86-64 has no rounding instruction).
inline int ceilToInt(double x) {
  const int i = static_cast<int>(x);
  return i + (x > i);
}

}  // namespace

long Footprint::area() const {
  long sum = 0;
  for (int y = y0; y < y1; ++y) sum += spans[y - y0].x1 - spans[y - y0].x0;
  return sum;
}

ShapeRasterizer::ShapeRasterizer(int points_per_circle) {
  const int n = std::max(3, points_per_circle);
  // Radius of the regular n-gon whose area equals the circle's.
  const double scale = std::sqrt(2 * M_PI / (n * std::sin(2 * M_PI / n)));
  for (int i = 0; i < n; ++i) {
    cos_.push_back(scale * std::cos(2 * M_PI * i / n));
    sin_.push_back(scale * std::sin(2 * M_PI * i / n));
  }
  projected_.reserve(2 * n);
  hull_.reserve(2 * n + 1);
  for (auto& xs : chain_x_) xs.resize(kMaxImageRows);
}

bool ShapeRasterizer::outline(const Shape& shape, const Eigen::Isometry3d& pose,
                              const CameraModel& camera) {
  projected_.clear();
  const int n = static_cast<int>(cos_.size());
  // Everything in camera coordinates: one rotation per point saved.
  const Eigen::Matrix3d rot = camera.rotation * pose.linear();
  const Eigen::Vector3d origin = camera.toCamera(pose.translation());
  auto emit = [&](const Eigen::Vector3d& p) {
    if (p.z() < CameraModel::kMinDepth) return false;
    projected_.push_back(camera.projectCameraPoint(p));
    return true;
  };
  if (shape.type == ShapeType::kTruncatedCone) {
    const Eigen::Vector3d axis = rot * shape.axis;
    const Eigen::Vector3d u = axis.unitOrthogonal();
    const Eigen::Vector3d v = axis.cross(u);
    const Eigen::Vector3d far_end = origin + axis * shape.length;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d dir = cos_[i] * u + sin_[i] * v;
      if (!emit(origin + shape.radius_start * dir) || !emit(far_end + shape.radius_end * dir))
        return false;
    }
    return true;
  }
  if (shape.type == ShapeType::kEllipsoid) {
    // In the frame where the ellipsoid is the unit sphere, the contour seen from the camera centre o
    // is the circle {u : u.o = 1}: centre o/|o|^2, radius sqrt(1 - 1/|o|^2), normal o.
    const Eigen::Vector3d centre = origin + rot * shape.center;
    const Eigen::Vector3d o = (rot.transpose() * -centre).cwiseQuotient(shape.radii);
    const double d2 = o.squaredNorm();
    if (d2 <= 1.0 + 1e-9) return false;  // camera inside the ellipsoid
    const Eigen::Vector3d m = o / d2;
    const double rho = std::sqrt(1.0 - 1.0 / d2);
    const Eigen::Vector3d e1 = o.unitOrthogonal();
    const Eigen::Vector3d e2 = o.normalized().cross(e1);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d unit = m + rho * (cos_[i] * e1 + sin_[i] * e2);
      if (!emit(centre + rot * unit.cwiseProduct(shape.radii))) return false;
    }
    return true;
  }
  return false;
}

void convexHull(std::vector<Eigen::Vector2d>& points, std::vector<Eigen::Vector2d>& hull) {
  hull.clear();
  const std::size_t n = points.size();
  if (n < 3) {
    hull = points;
    return;
  }
  std::sort(points.begin(), points.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  hull.resize(2 * n);
  std::size_t k = 0;
  for (std::size_t i = 0; i < n; ++i) {  // lower chain
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (std::size_t i = n - 1, lower = k + 1; i-- > 0;) {  // upper chain
    while (k >= lower && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
}

Footprint ShapeRasterizer::scanConvexHull(const CameraModel& camera, RowSpan* buffer) {
  Footprint f;
  const int n = static_cast<int>(hull_.size());
  if (n < 3) return f;
  int top = 0, bottom = 0;
  for (int i = 1; i < n; ++i) {
    if (hull_[i].y() < hull_[top].y()) top = i;
    if (hull_[i].y() > hull_[bottom].y()) bottom = i;
  }
  // Rows whose centre lies in [ytop, ybottom), top-left rule.
  const int y0 = std::max(0, static_cast<int>(std::ceil(hull_[top].y())));
  const int y1 = std::min({camera.height, kMaxImageRows,
                           static_cast<int>(std::ceil(hull_[bottom].y()))});
  if (y0 >= y1) return f;

  // Each chain from the top vertex to the bottom vertex (one forward, one backward) writes its x for
  // every row its edges cross; a row then takes the smaller as left and the larger as right edge.
  const int rows = y1 - y0;
  double* xa = chain_x_[0].data();
  double* xb = chain_x_[1].data();
  auto walk = [&](int step, double* out) {
    for (int v = top; v != bottom;) {
      const int to = (v + step) % n;
      const Eigen::Vector2d& p = hull_[v];
      const Eigen::Vector2d& q = hull_[to];
      // Rows whose centre lies in [p.y, q.y), clipped to the image.
      const int from_row = std::max(y0, ceilToInt(std::max(p.y(), 0.0)));
      const int to_row = std::min(y1, ceilToInt(std::clamp(q.y(), 0.0, double(y1))));
      if (to_row > from_row) {
        const double slope = (q.x() - p.x()) / (q.y() - p.y());
        double x = p.x() + slope * (from_row - p.y());
        for (int y = from_row; y < to_row; ++y, x += slope) out[y - y0] = x;
      }
      v = to;
    }
  };
  walk(1, xa);
  walk(n - 1, xb);
  const double width = camera.width;
  int xmin = camera.width, xmax = 0;
  int first = -1, last = -1;
  for (int r = 0; r < rows; ++r) {
    // Clamped first, so the integer conversion is safe for any projection.
    const double left = std::clamp(std::min(xa[r], xb[r]), 0.0, width);
    const double right = std::clamp(std::max(xa[r], xb[r]), left, width);
    const int x0 = ceilToInt(left);
    const int x1 = ceilToInt(right);
    buffer[r].x0 = static_cast<int16_t>(x0);
    buffer[r].x1 = static_cast<int16_t>(x1);
    if (x1 > x0) {
      if (first < 0) first = y0 + r;
      last = y0 + r;
      xmin = std::min(xmin, x0);
      xmax = std::max(xmax, x1);
    }
  }
  if (first < 0) return f;
  // Trim empty rows at both ends so the box is tight; spans stay relative to the new y0.
  if (first > y0) std::copy(buffer + (first - y0), buffer + (last - y0 + 1), buffer);
  f.y0 = first;
  f.y1 = last + 1;
  f.xmin = xmin;
  f.xmax = xmax;
  f.spans = buffer;
  return f;
}

Footprint ShapeRasterizer::rasterize(const Shape& shape, const Eigen::Isometry3d& pose,
                                     const CameraModel& camera, RowSpan* buffer) {
  hull_.clear();
  if (!outline(shape, pose, camera)) return {};
  convexHull(projected_, hull_);
  return scanConvexHull(camera, buffer);
}

}  // namespace mocap
