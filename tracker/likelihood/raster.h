// Rasterization of one segment's projection as one span per image row (the projection of a
// truncated cone or an ellipsoid is convex), restricted to its bounding box. Pixel (x, y) is inside
// when its centre is, with the top-left fill rule, so adjacent shapes never share a pixel twice.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

// Footprints are clipped to this many rows (the int16 spans allow up to 32767 columns too).
inline constexpr int kMaxImageRows = 8192;

struct RowSpan {
  int16_t x0 = 0;  // first column inside
  int16_t x1 = 0;  // one past the last column inside (x1 == x0: empty row)
};

// One shape's rasterized projection in one camera: rows [y0, y1), spans[y - y0], columns inside
// [xmin, xmax). The spans are borrowed (see ShapeRasterizer::rasterize).
struct Footprint {
  int y0 = 0, y1 = 0;
  int xmin = 0, xmax = 0;
  const RowSpan* spans = nullptr;

  bool empty() const { return y1 <= y0; }
  long area() const;
  bool overlapsBox(const Footprint& o) const {
    return y0 < o.y1 && o.y0 < y1 && xmin < o.xmax && o.xmin < xmax;
  }
};

// Turns shapes into footprints. Holds the per-thread scratch (outline points, hull): one per
// worker. `points_per_circle` sets the outline tessellation; each circle is replaced by the
// polygon of equal area, so coarse outlines neither shrink nor grow the shape.
class ShapeRasterizer {
 public:
  explicit ShapeRasterizer(int points_per_circle);

  // Rasterizes `shape` placed at `pose` (segment frame -> world) in `camera`, writing the spans
  // into `buffer` (capacity: camera.height rows). Returns an empty footprint if the shape has no
  // outline, lies behind the camera or outside the image.
  Footprint rasterize(const Shape& shape, const Eigen::Isometry3d& pose, const CameraModel& camera,
                      RowSpan* buffer);

  // The projected outline polygon of the last call (convex hull, pixels), for drawing and tests.
  const std::vector<Eigen::Vector2d>& lastHull() const { return hull_; }

 private:
  bool outline(const Shape& shape, const Eigen::Isometry3d& pose, const CameraModel& camera);
  Footprint scanConvexHull(const CameraModel& camera, RowSpan* buffer);
  // The same, filling per-row arrays chain by chain: the fallback for hulls whose chains are not
  // y-monotone after rounding.
  Footprint scanChains(const CameraModel& camera, int y0, int y1, int top, int bottom,
                       RowSpan* buffer);
  static Footprint trim(RowSpan* buffer, int y0, int first, int last, int xmin, int xmax);

  std::vector<double> cos_, sin_;           // unit circle, area-matched radius folded in
  std::vector<Eigen::Vector2d> projected_;  // 2 points per circle point; the first count used
  int projected_count_ = 0;
  std::vector<Eigen::Vector2d> hull_;
  std::vector<double> chain_x_[2];  // per row, the x of each hull chain
};

// Convex hull (Andrew's monotone chain) of `points`, counter-clockwise in a y-up frame, without
// repeated end point. Exposed for tests.
void convexHull(std::vector<Eigen::Vector2d>& points, std::vector<Eigen::Vector2d>& hull);

}  // namespace mocap
