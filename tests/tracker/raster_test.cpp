// Rasterized footprints against analytic areas, and scan conversion against a brute-force
// point-in-polygon test of every pixel centre.
#include "tracker/raster.h"

#include <gtest/gtest.h>

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
  EXPECT_NEAR(coarse.rasterize(s, at(0, 0, d), cam, buffer.data()).area(), expected, 0.03 * expected);
}

TEST(Raster, SideOnTruncatedConeIsATrapezoidUnderWeakPerspective) {
  // Far away (depth 10 m, f = 5000 px: 500 px per metre), a cone lying across the view projects to a
  // trapezoid of area L * (r0 + r1) * 500^2; the end circles are seen edge-on.
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
    pose.rotate(Eigen::AngleAxisd(3 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()));
    const Footprint f = raster.rasterize(s, pose, cam, buffer.data());
    const std::vector<Eigen::Vector2d>& hull = raster.lastHull();
    for (int y = 0; y < cam.height; ++y) {
      for (int x = 0; x < cam.width; ++x) {
        const bool in_spans = y >= f.y0 && y < f.y1 && x >= f.spans[y - f.y0].x0 &&
                              x < f.spans[y - f.y0].x1;
        // Centres exactly on an edge may go either way (fill rule); skip a hair around edges.
        const bool inside = insideConvex(hull, x, y);
        const bool inside_grown = insideConvex(hull, x, y) || insideConvex(hull, x + 1e-6, y + 1e-6) ||
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

TEST(Raster, ConvexHullDropsInteriorPoints) {
  std::vector<Eigen::Vector2d> pts = {{0, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}, {0.5, 1.5}, {1, 0}};
  std::vector<Eigen::Vector2d> hull;
  convexHull(pts, hull);
  EXPECT_EQ(hull.size(), 4u);
}

}  // namespace
}  // namespace mocap
