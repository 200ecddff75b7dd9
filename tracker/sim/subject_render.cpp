// Subject rendering: projected convex outlines, scan conversion, per-pixel ray tests and shading
// (see subject_render.h).
#include "tracker/sim/subject_render.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tracker/likelihood/raster.h"

namespace mocap {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr int kContourPoints = 24;
// The polygon of kContourPoints on a circle of this times the radius has the circle's area.
const double kAreaMatch =
    std::sqrt(2 * M_PI / (kContourPoints * std::sin(2 * M_PI / kContourPoints)));
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// First hit with t > 0 of o + t d (local frame) on the unit sphere.
bool hitSphere(const Vector3d& o, const Vector3d& d, double& t, Vector3d& n) {
  const double a = d.squaredNorm(), b = o.dot(d), c = o.squaredNorm() - 1;
  const double disc = b * b - a * c;
  if (disc < 0) return false;
  t = (-b - std::sqrt(disc)) / a;
  n = o + t * d;
  return t > 0;
}

// The round cone: the hull of spheres ra at the origin and rb at (0, 0, len). The lateral surface
// is the cone tangent to both; a ray that misses that cone misses the caps too.
bool hitRoundCone(const Vector3d& o, const Vector3d& d_in, double len, double ra, double rb,
                  double& t, Vector3d& n) {
  const double scale = d_in.norm();
  const Vector3d d = d_in / scale;
  if (len <= std::abs(ra - rb) + 1e-9) {  // one sphere holds the other
    const double r = std::max(ra, rb);
    const Vector3d c = ra >= rb ? Vector3d::Zero() : Vector3d(0, 0, len);
    if (!hitSphere((o - c) / r, d / r, t, n)) return false;
    t /= scale;
    return true;
  }
  const Vector3d ba(0, 0, len);
  const Vector3d ob = o - ba;
  const double rr = ra - rb;
  const double m0 = len * len, m1 = len * o.z(), m2 = len * d.z(), m3 = d.dot(o),
               m5 = o.squaredNorm(), m6 = ob.dot(d), m7 = ob.squaredNorm();
  const double d2 = m0 - rr * rr;
  const double k2 = d2 - m2 * m2;
  const double k1 = d2 * m3 - m1 * m2 + m2 * rr * ra;
  const double k0 = d2 * m5 - m1 * m1 + 2 * m1 * rr * ra - m0 * ra * ra;
  const double h = k1 * k1 - k0 * k2;
  if (h < 0) return false;
  if (std::abs(k2) > 1e-12) {
    const double tb = (-std::sqrt(h) - k1) / k2;
    const double y = m1 - ra * rr + tb * m2;
    if (y > 0 && y < d2) {
      if (tb <= 0) return false;
      t = tb / scale;
      n = d2 * (o + tb * d) - ba * y;
      return true;
    }
  }
  const double h1 = m3 * m3 - m5 + ra * ra, h2 = m6 * m6 - m7 + rb * rb;
  double best = kInfinity;
  if (h1 > 0) {
    const double tc = -m3 - std::sqrt(h1);
    if (tc > 0) best = tc, n = o + tc * d;
  }
  if (h2 > 0) {
    const double tc = -m6 - std::sqrt(h2);
    if (tc > 0 && tc < best) best = tc, n = ob + tc * d;
  }
  if (best == kInfinity) return false;
  t = best / scale;
  return true;
}

// The frustum: radius r0 at z = 0 to r1 at z = len, flat ends.
bool hitFrustum(const Vector3d& o, const Vector3d& d, double len, double r0, double r1, double& t,
                Vector3d& n) {
  const double k = (r1 - r0) / len;
  const double base = r0 + k * o.z();
  const double a = d.x() * d.x() + d.y() * d.y() - k * k * d.z() * d.z();
  const double b = o.x() * d.x() + o.y() * d.y() - k * d.z() * base;
  const double c = o.x() * o.x() + o.y() * o.y() - base * base;
  double best = kInfinity;
  auto side = [&](double tc) {
    const double z = o.z() + tc * d.z();
    if (tc > 0 && tc < best && z >= 0 && z <= len) {
      best = tc;
      const Vector3d p = o + tc * d;
      n = Vector3d(p.x(), p.y(), -k * (r0 + k * z));
    }
  };
  if (std::abs(a) > 1e-12) {
    const double disc = b * b - a * c;
    if (disc >= 0) {
      const double root = std::sqrt(disc);
      side((-b - root) / a);
      side((-b + root) / a);
    }
  } else if (std::abs(b) > 1e-12) {
    side(-c / (2 * b));
  }
  if (std::abs(d.z()) > 1e-12) {
    for (int end : {0, 1}) {
      const double z = end ? len : 0, r = end ? r1 : r0;
      const double tc = (z - o.z()) / d.z();
      const Vector3d p = o + tc * d;
      if (tc > 0 && tc < best && p.x() * p.x() + p.y() * p.y() <= r * r) {
        best = tc;
        n = Vector3d(0, 0, end ? 1 : -1);
      }
    }
  }
  if (best == kInfinity) return false;
  t = best;
  return true;
}

bool hitLocal(const SubjectPrimitive& p, const Vector3d& o, const Vector3d& d, double& t,
              Vector3d& n) {
  switch (p.kind) {
    case SubjectPrimitive::Kind::kEllipsoid:
      return hitSphere(o, d, t, n);
    case SubjectPrimitive::Kind::kRoundCone:
      return hitRoundCone(o, d, p.length, p.radius0, p.radius1, t, n);
    case SubjectPrimitive::Kind::kFrustum:
      return hitFrustum(o, d, p.length, p.radius0, p.radius1, t, n);
  }
  return false;
}

// For a pixel inside the outline whose ray grazes past the surface (the outline polygon is a
// fraction of a pixel off the true one): the closest approach to the primitive's axis, its normal
// square to the ray.
void grazeLocal(const SubjectPrimitive& p, const Vector3d& o, const Vector3d& d, double& t,
                Vector3d& n) {
  const Vector3d middle(0, 0, p.kind == SubjectPrimitive::Kind::kEllipsoid ? 0 : 0.5 * p.length);
  t = std::max(1e-6, (middle - o).dot(d) / d.squaredNorm());
  n = o + t * d - middle;
  if (p.kind != SubjectPrimitive::Kind::kEllipsoid) n.z() = 0;
}

cv::Vec3b materialColour(SubjectMaterial m, const Clothing& c) {
  switch (m) {
    case SubjectMaterial::kSkin:
      return c.skin;
    case SubjectMaterial::kHair:
      return c.hair;
    case SubjectMaterial::kTop:
      return c.top;
    case SubjectMaterial::kBottom:
      return c.bottom;
    case SubjectMaterial::kCoat:
      return c.coat_colour;
    case SubjectMaterial::kShoe:
      return c.shoe_colour;
  }
  return c.skin;
}

}  // namespace

bool intersectSubjectPrimitive(const SubjectPrimitive& p, const Vector3d& origin,
                               const Vector3d& direction, double& t, Vector3d& normal) {
  const Matrix3d inverse = p.linear.inverse();
  Vector3d n;
  if (!hitLocal(p, inverse * (origin - p.origin), inverse * direction, t, n)) return false;
  normal = (inverse.transpose() * n).normalized();
  return true;
}

void SubjectRasterizer::addContour(const Vector3d& centre, const Matrix3d& shape,
                                   const CameraModel& camera) {
  // The ellipsoid centre + shape * (unit ball); its contour seen from the camera centre is, in
  // unit-ball coordinates, the circle of tangency of the cone from the centre's image there.
  const Vector3d eye = shape.inverse() * (camera.center() - centre);
  const double distance = eye.norm();
  if (distance <= 1 + 1e-9) {
    behind_ = true;
    return;
  }
  const Vector3d axis = eye / distance;
  const Vector3d mid = axis / distance;
  const double radius = std::sqrt(1 - 1 / (distance * distance)) * kAreaMatch;
  const Vector3d e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
  for (int i = 0; i < kContourPoints; ++i) {
    const double a = 2 * M_PI * i / kContourPoints;
    Vector2d pixel;
    const Vector3d u = mid + radius * (std::cos(a) * e1 + std::sin(a) * e2);
    if (!camera.project(centre + shape * u, pixel)) behind_ = true;
    points_.push_back(pixel);
  }
}

void SubjectRasterizer::addDisc(const Vector3d& centre, const Matrix3d& shape,
                                const CameraModel& camera) {
  for (int i = 0; i < kContourPoints; ++i) {
    const double a = 2 * M_PI * i / kContourPoints;
    Vector2d pixel;
    const Vector3d u(kAreaMatch * std::cos(a), kAreaMatch * std::sin(a), 0);
    if (!camera.project(centre + shape * u, pixel)) behind_ = true;
    points_.push_back(pixel);
  }
}

bool SubjectRasterizer::scanPrimitive(const SubjectPrimitive& p, const CameraModel& camera) {
  points_.clear();
  behind_ = false;
  if (p.kind == SubjectPrimitive::Kind::kEllipsoid) {
    addContour(p.origin, p.linear, camera);
  } else {
    const Vector3d end = p.origin + p.linear.col(2) * p.length;
    if (p.kind == SubjectPrimitive::Kind::kRoundCone) {
      addContour(p.origin, p.linear * p.radius0, camera);
      addContour(end, p.linear * p.radius1, camera);
    } else {
      Matrix3d flat = p.linear;
      flat.col(2).setZero();
      addDisc(p.origin, flat * p.radius0, camera);
      addDisc(end, flat * p.radius1, camera);
    }
  }
  // A piece reaching behind the camera is left out (a subject is well in front of the cameras).
  if (behind_ || points_.size() < 3) return false;
  convexHull(points_, hull_);
  if (hull_.size() < 3) return false;
  double ymin = kInfinity, ymax = -kInfinity;
  for (const Vector2d& v : hull_) ymin = std::min(ymin, v.y()), ymax = std::max(ymax, v.y());
  // Pixel centres (x, y) inside: rows with ymin <= y < ymax, columns lo <= x < hi.
  rows_.y0 = std::max(0, static_cast<int>(std::ceil(ymin)));
  rows_.y1 = std::min(camera.height, static_cast<int>(std::ceil(ymax)));
  if (rows_.y1 <= rows_.y0) return false;
  const int count = rows_.y1 - rows_.y0;
  lo_.assign(count, kInfinity);
  hi_.assign(count, -kInfinity);
  for (std::size_t i = 0; i < hull_.size(); ++i) {
    const Vector2d& a = hull_[i];
    const Vector2d& b = hull_[(i + 1) % hull_.size()];
    if (a.y() == b.y()) continue;
    const int first = std::max(rows_.y0, static_cast<int>(std::ceil(std::min(a.y(), b.y()))));
    const int last = std::min(rows_.y1, static_cast<int>(std::ceil(std::max(a.y(), b.y()))));
    const double slope = (b.x() - a.x()) / (b.y() - a.y());
    for (int y = first; y < last; ++y) {
      const double x = a.x() + (y - a.y()) * slope;
      lo_[y - rows_.y0] = std::min(lo_[y - rows_.y0], x);
      hi_[y - rows_.y0] = std::max(hi_[y - rows_.y0], x);
    }
  }
  rows_.x0.resize(count);
  rows_.x1.resize(count);
  for (int i = 0; i < count; ++i) {
    if (!(hi_[i] >= lo_[i])) {
      rows_.x0[i] = rows_.x1[i] = 0;
      continue;
    }
    rows_.x0[i] = std::clamp(static_cast<int>(std::ceil(lo_[i])), 0, camera.width);
    rows_.x1[i] = std::clamp(static_cast<int>(std::ceil(hi_[i])), rows_.x0[i], camera.width);
  }
  return true;
}

void SubjectRasterizer::renderSilhouette(const PosedSubject& subject, const CameraModel& camera,
                                         cv::Mat& mask) {
  mask.create(camera.height, camera.width, CV_8UC1);
  mask.setTo(0);
  for (const SubjectPrimitive& p : subject.primitives) {
    if (!scanPrimitive(p, camera)) continue;
    for (int y = rows_.y0; y < rows_.y1; ++y) {
      uint8_t* row = mask.ptr<uint8_t>(y);
      std::fill(row + rows_.x0[y - rows_.y0], row + rows_.x1[y - rows_.y0], uint8_t{255});
    }
  }
}

const cv::Mat* SubjectRasterizer::pixelRays(const CameraModel& camera) {
  if (std::all_of(camera.distortion.begin(), camera.distortion.end(),
                  [](double k) { return k == 0; }))
    return nullptr;
  for (const RayTable& table : ray_tables_) {
    const CameraModel& c = table.camera;
    if (c.width == camera.width && c.height == camera.height && c.fx == camera.fx &&
        c.fy == camera.fy && c.cx == camera.cx && c.cy == camera.cy &&
        c.distortion == camera.distortion)
      return &table.rays;
  }
  // Undistorted normalised coordinates of every pixel, once per camera (backProject in the
  // camera frame: the rotation cancels).
  CameraModel intrinsics = camera;
  intrinsics.rotation.setIdentity();
  intrinsics.translation.setZero();
  cv::Mat rays(camera.height, camera.width, CV_32FC2);
  for (int y = 0; y < camera.height; ++y) {
    auto* row = rays.ptr<cv::Vec2f>(y);
    for (int x = 0; x < camera.width; ++x) {
      const Vector3d ray = intrinsics.backProject(Vector2d(x, y));
      row[x] =
          cv::Vec2f(static_cast<float>(ray.x() / ray.z()), static_cast<float>(ray.y() / ray.z()));
    }
  }
  if (ray_tables_.size() >= 8) ray_tables_.erase(ray_tables_.begin());
  ray_tables_.push_back({intrinsics, rays});
  return &ray_tables_.back().rays;
}

void SubjectRasterizer::shadePrimitive(const SubjectPrimitive& p, const CameraModel& camera,
                                       const cv::Mat* rays, const Clothing& clothing,
                                       PersonLayer& layer) {
  // In the primitive's frame, with the ray of pixel (x, y) the camera-frame (xn, yn, 1): t is
  // the camera depth.
  const Matrix3d to_local = (camera.rotation * p.linear).inverse();
  const Vector3d eye = to_local * (-(camera.rotation * p.origin + camera.translation));
  const Matrix3d normal_to_world = p.linear.inverse().transpose();
  const Vector3d step = to_local.col(0) / camera.fx;
  const cv::Vec3b colour = materialColour(p.material, clothing);
  const double ambient = lighting_.ambient;
  for (int y = rows_.y0; y < rows_.y1; ++y) {
    const int x0 = rows_.x0[y - rows_.y0], x1 = rows_.x1[y - rows_.y0];
    float* depth = layer.depth.ptr<float>(y);
    cv::Vec3b* out = layer.colour.ptr<cv::Vec3b>(y);
    uint8_t* mask = layer.mask.ptr<uint8_t>(y);
    const cv::Vec2f* ray_row = rays ? rays->ptr<cv::Vec2f>(y) : nullptr;
    Vector3d d = to_local.col(0) * ((x0 - camera.cx) / camera.fx) +
                 to_local.col(1) * ((y - camera.cy) / camera.fy) + to_local.col(2);
    for (int x = x0; x < x1; ++x, d += step) {
      if (ray_row) d = to_local * Vector3d(ray_row[x][0], ray_row[x][1], 1);
      double t;
      Vector3d n;
      if (!hitLocal(p, eye, d, t, n)) grazeLocal(p, eye, d, t, n);
      if (!(t < depth[x])) continue;
      depth[x] = static_cast<float>(t);
      mask[x] = 255;
      const Vector3d world_normal = (normal_to_world * n).normalized();
      const double light = std::max(0.0, world_normal.dot(lighting_.toward_light));
      const double shade = ambient + (1 - ambient) * light;
      out[x] = cv::Vec3b(cv::saturate_cast<uint8_t>(colour[0] * shade),
                         cv::saturate_cast<uint8_t>(colour[1] * shade),
                         cv::saturate_cast<uint8_t>(colour[2] * shade));
    }
  }
}

void SubjectRasterizer::renderLayer(const PosedSubject& subject, const CameraModel& camera,
                                    PersonLayer& layer) {
  layer.mask.create(camera.height, camera.width, CV_8UC1);
  layer.colour.create(camera.height, camera.width, CV_8UC3);
  layer.depth.create(camera.height, camera.width, CV_32FC1);
  layer.mask.setTo(0);
  layer.colour.setTo(cv::Scalar::all(0));
  layer.depth.setTo(std::numeric_limits<float>::infinity());
  layer.chest = subject.chest;
  static const Clothing kDefaultClothing;
  const Clothing& clothing = subject.clothing ? *subject.clothing : kDefaultClothing;
  const cv::Mat* rays = pixelRays(camera);
  for (const SubjectPrimitive& p : subject.primitives) {
    if (scanPrimitive(p, camera)) shadePrimitive(p, camera, rays, clothing, layer);
  }
}

SubjectSceneRenderer::SubjectSceneRenderer(const BodyModel& model, const Rig& rig,
                                           const SubjectParams& params)
    : model_(model),
      rig_(rig),
      subject_(params, subjectJointsAt(model, model.neutralPose())),
      kinematics_(model_) {}

const PosedSubject& SubjectSceneRenderer::pose(const Eigen::VectorXd& q) {
  forwardKinematics(model_, kinematics_, q);
  subject_.pose(model_, kinematics_, posed_);
  truth_ = modelPointsFromJoints(model_, posed_.joints);
  return posed_;
}

void SubjectSceneRenderer::hideSegment(int camera, int segment) {
  // A bone is on the segment that carries the joint it starts from.
  for (int j = 1; j < kSubjectJointCount; ++j) {
    const int from = model_.pointIndex(kSubjectJointNames[subjectJointParent(j)]);
    if (from >= 0 && model_.points[from].segment == segment) hidden_.emplace_back(camera, j);
  }
}

const PosedSubject& SubjectSceneRenderer::visibleIn(int camera) {
  if (std::none_of(hidden_.begin(), hidden_.end(),
                   [&](const std::pair<int, int>& h) { return h.first == camera; }))
    return posed_;
  visible_.joints = posed_.joints;
  visible_.chest = posed_.chest;
  visible_.clothing = posed_.clothing;
  visible_.primitives.clear();
  for (const SubjectPrimitive& p : posed_.primitives)
    if (std::find(hidden_.begin(), hidden_.end(), std::pair<int, int>(camera, p.bone)) ==
        hidden_.end())
      visible_.primitives.push_back(p);
  return visible_;
}

std::vector<cv::Mat> SubjectSceneRenderer::renderSilhouettes(const Eigen::VectorXd& q) {
  std::vector<cv::Mat> images;
  renderSilhouettes(q, images);
  return images;
}

void SubjectSceneRenderer::renderSilhouettes(const Eigen::VectorXd& q,
                                             std::vector<cv::Mat>& images) {
  pose(q);
  images.resize(rig_.size());
  for (std::size_t c = 0; c < rig_.size(); ++c)
    rasterizer_.renderSilhouette(visibleIn(static_cast<int>(c)), rig_[c], images[c]);
}

void SubjectSceneRenderer::renderLayers(const Eigen::VectorXd& q,
                                        std::vector<PersonLayer>& layers) {
  pose(q);
  layers.resize(rig_.size());
  for (std::size_t c = 0; c < rig_.size(); ++c) rasterizer_.renderLayer(posed_, rig_[c], layers[c]);
}

}  // namespace mocap
