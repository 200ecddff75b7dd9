// Rasterized footprints against analytic areas, and scan conversion against a brute-force
// point-in-polygon test of every pixel centre.
#include "tracker/likelihood/raster.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace mocap {
namespace {

// A camera at the origin looking down +Z (camera frame == world frame).
CameraModel axisCamera(double focal, int width = 780, int height = 580) {
  CameraModel c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = focal;
  c.cx = width / 2.0;
  c.cy = height / 2.0;
  return c;
}

Eigen::Isometry3d at(double x, double y, double z) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(x, y, z);
  return t;
}

TEST(Raster, EllipsoidOnAxisMatchesAnalyticEllipseArea) {
  // Seen along its own axis c from distance d, an ellipsoid projects to an ellipse of semi-axes
  // f a / sqrt(d^2 - c^2) and f b / sqrt(d^2 - c^2).
  const CameraModel cam = axisCamera(1000);
  Shape s;
  s.type = ShapeType::kEllipsoid;
  s.radii = Eigen::Vector3d(0.2, 0.1, 0.05);
  const double d = 2.0;
  const double expected = M_PI * 1000 * 1000 * 0.2 * 0.1 / (d * d - 0.05 * 0.05);
  ShapeRasterizer raster(48);
  std::vector<RowSpan> buffer(cam.height);
  const Footprint f = raster.rasterize(s, at(0, 0, d), cam, buffer.data());
  EXPECT_NEAR(f.area(), expected, 0.005 * expected);
  // The coarse tracker outline is area-matched, so it stays close too.
  ShapeRasterizer coarse(8);
  EXPECT_NEAR(coarse.rasterize(s, at(0, 0, d), cam, buffer.data()).area(), expected,
              0.03 * expected);
}

TEST(Raster, SideOnTruncatedConeIsATrapezoidUnderWeakPerspective) {
  // Far away (depth 10 m, f = 5000 px: 500 px per metre), a cone lying across the view projects to
  // a trapezoid of area L * (r0 + r1) * 500^2; the end circles are seen edge-on.
  const CameraModel cam = axisCamera(5000);
  Shape s;
  s.type = ShapeType::kTruncatedCone;
  s.axis = Eigen::Vector3d::UnitX();
  s.length = 0.4;
  s.radius_start = 0.05;
  s.radius_end = 0.03;
  const double expected = 0.4 * (0.05 + 0.03) * 500.0 * 500.0;
  ShapeRasterizer raster(48);
  std::vector<RowSpan> buffer(cam.height);
  const Footprint f = raster.rasterize(s, at(-0.2, 0, 10), cam, buffer.data());
  EXPECT_NEAR(f.area(), expected, 0.01 * expected);
  EXPECT_NEAR(f.xmax - f.xmin, 200, 2);
  EXPECT_NEAR(f.y1 - f.y0, 50, 2);
}

bool insideConvex(const std::vector<Eigen::Vector2d>& hull, double x, double y) {
  // Counter-clockwise in a y-up frame: every edge keeps the point on its left (or on it).
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const Eigen::Vector2d& a = hull[i];
    const Eigen::Vector2d& b = hull[(i + 1) % hull.size()];
    if ((b.x() - a.x()) * (y - a.y()) - (b.y() - a.y()) * (x - a.x()) < 0) return false;
  }
  return true;
}

TEST(Raster, SpansHoldExactlyThePixelCentresInsideTheHull) {
  CameraModel cam = axisCamera(600, 320, 240);
  cam.distortion = {-0.1, 0.02, 0, 0, 0};
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  ShapeRasterizer raster(8);
  std::vector<RowSpan> buffer(cam.height);
  int checked = 0;
  for (int trial = 0; trial < 60; ++trial) {
    Shape s;
    s.type = trial % 2 ? ShapeType::kEllipsoid : ShapeType::kTruncatedCone;
    s.axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    s.length = 0.3 + 0.2 * u(rng);
    s.radius_start = 0.06 + 0.03 * u(rng);
    s.radius_end = 0.04 + 0.02 * u(rng);
    s.radii = Eigen::Vector3d(0.15, 0.08, 0.05) * (1.2 + 0.5 * u(rng));
    Eigen::Isometry3d pose = at(0.4 * u(rng), 0.3 * u(rng), 1.5 + 0.3 * u(rng));
    pose.rotate(
        Eigen::AngleAxisd(3 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()));
    const Footprint f = raster.rasterize(s, pose, cam, buffer.data());
    const std::vector<Eigen::Vector2d>& hull = raster.lastHull();
    for (int y = 0; y < cam.height; ++y) {
      for (int x = 0; x < cam.width; ++x) {
        const bool in_spans =
            y >= f.y0 && y < f.y1 && x >= f.spans[y - f.y0].x0 && x < f.spans[y - f.y0].x1;
        // Centres exactly on an edge may go either way (fill rule); skip a hair around edges.
        const bool inside = insideConvex(hull, x, y);
        const bool inside_grown = insideConvex(hull, x, y) ||
                                  insideConvex(hull, x + 1e-6, y + 1e-6) ||
                                  insideConvex(hull, x - 1e-6, y - 1e-6);
        if (inside != inside_grown) continue;
        ASSERT_EQ(in_spans, inside) << "trial " << trial << " pixel " << x << "," << y;
        checked += inside;
      }
    }
  }
  EXPECT_GT(checked, 10000);  // the shapes really covered pixels
}

TEST(Raster, ShapesBehindTheCameraOrOffImageGiveEmptyFootprints) {
  const CameraModel cam = axisCamera(1000);
  Shape s;
  s.type = ShapeType::kEllipsoid;
  s.radii = Eigen::Vector3d(0.1, 0.1, 0.1);
  ShapeRasterizer raster(8);
  std::vector<RowSpan> buffer(cam.height);
  EXPECT_TRUE(raster.rasterize(s, at(0, 0, -2), cam, buffer.data()).empty());
  EXPECT_TRUE(raster.rasterize(s, at(5, 0, 2), cam, buffer.data()).empty());
  EXPECT_TRUE(raster.rasterize(s, at(0, 0, 0.05), cam, buffer.data()).empty());  // camera inside
  Shape none;
  EXPECT_TRUE(raster.rasterize(none, at(0, 0, 2), cam, buffer.data()).empty());
}

// The scan conversion written plainly: every chain edge fills a per-row x array (later edges
// overwrite), then each row takes the clamped smaller and larger x, rounded up.
Footprint referenceScan(const std::vector<Eigen::Vector2d>& hull, const CameraModel& camera,
                        std::vector<RowSpan>& spans) {
  const int n = static_cast<int>(hull.size());
  if (n < 3) return {};
  int top = 0, bottom = 0;
  for (int i = 1; i < n; ++i) {
    if (hull[i].y() < hull[top].y()) top = i;
    if (hull[i].y() > hull[bottom].y()) bottom = i;
  }
  const int y0 = std::max(0, static_cast<int>(std::ceil(hull[top].y())));
  const int y1 = std::min(camera.height, static_cast<int>(std::ceil(hull[bottom].y())));
  if (y0 >= y1) return {};
  std::vector<double> xs[2];
  for (int chain = 0; chain < 2; ++chain) {
    xs[chain].assign(y1 - y0, 0.0);
    const int step = chain == 0 ? 1 : n - 1;
    for (int v = top; v != bottom; v = (v + step) % n) {
      const Eigen::Vector2d& p = hull[v];
      const Eigen::Vector2d& q = hull[(v + step) % n];
      const int from = std::max(y0, static_cast<int>(std::ceil(std::max(p.y(), 0.0))));
      const int to = std::min(y1, static_cast<int>(std::ceil(std::clamp(q.y(), 0.0, double(y1)))));
      if (to <= from) continue;
      const double slope = (q.x() - p.x()) / (q.y() - p.y());
      double x = p.x() + slope * (from - p.y());
      for (int y = from; y < to; ++y, x += slope) xs[chain][y - y0] = x;
    }
  }
  Footprint f{camera.height, -1, camera.width, 0, nullptr};
  spans.assign(y1 - y0, RowSpan{});
  for (int y = y0; y < y1; ++y) {
    const double a = xs[0][y - y0], b = xs[1][y - y0];
    const double left = std::clamp(std::min(a, b), 0.0, double(camera.width));
    const double right = std::clamp(std::max(a, b), left, double(camera.width));
    const int x0 = static_cast<int>(std::ceil(left)), x1 = static_cast<int>(std::ceil(right));
    spans[y - y0] = {static_cast<int16_t>(x0), static_cast<int16_t>(x1)};
    if (x1 > x0) {
      f.y0 = std::min(f.y0, y);
      f.y1 = y + 1;
      f.xmin = std::min(f.xmin, x0);
      f.xmax = std::max(f.xmax, x1);
    }
  }
  if (f.y1 < 0) return {};
  f.spans = spans.data() + (f.y0 - y0);
  return f;
}

TEST(Raster, SpansEqualThePlainScanOfTheHullBitForBit) {
  // Shapes inside, across the border of and mostly off the image, thin and edge-on ones included,
  // with and without lens distortion: the spans must equal the plain scan exactly (the tracker's
  // results depend on every pixel).
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<RowSpan> buffer(580), expected_spans;
  long rows = 0, clipped_shapes = 0, gaps = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    CameraModel cam = axisCamera(800);
    if (trial % 3 == 0) cam.distortion = {-0.1, 0.02, 0.001, -0.001, 0};
    ShapeRasterizer raster(trial % 4 == 0 ? 5 : 8);
    Shape s;
    s.type = trial % 2 ? ShapeType::kEllipsoid : ShapeType::kTruncatedCone;
    s.axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    s.length = 0.05 + 0.04 * u(rng);
    s.radius_start = 0.01 + 0.009 * u(rng);
    s.radius_end = trial % 5 == 0 ? 0.0005 : 0.008 + 0.007 * u(rng);
    s.radii =
        Eigen::Vector3d(0.03 + 0.02 * u(rng), 0.01 + 0.009 * u(rng), 0.0005 + 0.0004 * u(rng));
    Eigen::Isometry3d pose = at(0.5 * u(rng), 0.4 * u(rng), 0.8 + 0.3 * u(rng));
    const Eigen::Vector3d turn_axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    pose.rotate(Eigen::AngleAxisd(3 * u(rng), turn_axis));
    const Footprint f = raster.rasterize(s, pose, cam, buffer.data());
    const Footprint e = referenceScan(raster.lastHull(), cam, expected_spans);
    ASSERT_EQ(f.empty(), e.empty()) << "trial " << trial;
    if (e.empty()) continue;
    ASSERT_EQ(f.y0, e.y0) << "trial " << trial;
    ASSERT_EQ(f.y1, e.y1) << "trial " << trial;
    ASSERT_EQ(f.xmin, e.xmin) << "trial " << trial;
    ASSERT_EQ(f.xmax, e.xmax) << "trial " << trial;
    for (int y = e.y0; y < e.y1; ++y) {
      ASSERT_EQ(f.spans[y - f.y0].x0, e.spans[y - e.y0].x0) << "trial " << trial << " row " << y;
      ASSERT_EQ(f.spans[y - f.y0].x1, e.spans[y - e.y0].x1) << "trial " << trial << " row " << y;
    }
    rows += e.y1 - e.y0;
    bool clipped = false;
    for (const Eigen::Vector2d& p : raster.lastHull())
      clipped = clipped || p.x() < 1 || p.x() > cam.width - 1 || p.y() < 0 || p.y() > cam.height;
    clipped_shapes += clipped;
    for (int y = e.y0; y < e.y1; ++y) gaps += e.spans[y - e.y0].x0 == e.spans[y - e.y0].x1;
  }
  EXPECT_GT(rows, 50000);
  EXPECT_GT(clipped_shapes, 100);  // the clamped path
  EXPECT_GT(gaps, 10);             // empty rows inside a footprint (slivers)
}

TEST(Raster, ConvexHullDropsInteriorPoints) {
  std::vector<Eigen::Vector2d> pts = {{0, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}, {0.5, 1.5}, {1, 0}};
  std::vector<Eigen::Vector2d> hull;
  convexHull(pts, hull);
  EXPECT_EQ(hull.size(), 4u);
}

}  // namespace
}  // namespace mocap
