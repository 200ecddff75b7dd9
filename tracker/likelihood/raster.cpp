// Shape outlines, their convex hull in the image, and scan conversion into row spans.
#include "tracker/likelihood/raster.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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
  projected_.resize(2 * n);
  hull_.reserve(4 * n);  // room for the hull algorithm's 2 entries per point
  for (auto& xs : chain_x_) xs.resize(kMaxImageRows);
}

bool ShapeRasterizer::outline(const Shape& shape, const Eigen::Isometry3d& pose,
                              const CameraModel& camera) {
  projected_count_ = 0;
  const int n = static_cast<int>(cos_.size());
  // Everything in camera coordinates: one rotation per point saved.
  const Eigen::Matrix3d rot = camera.rotation * pose.linear();
  const Eigen::Vector3d origin = camera.toCamera(pose.translation());
  // Without distortion the model's polynomial terms are exact zeros and ones, so the plain pinhole
  // gives bit-identical pixels without the call.
  const bool pinhole = std::all_of(camera.distortion.begin(), camera.distortion.end(),
                                   [](double k) { return k == 0; });
  Eigen::Vector2d* out = projected_.data();
  auto emit = [&](const Eigen::Vector3d& p) {
    if (p.z() < CameraModel::kMinDepth) return false;
    Eigen::Vector2d& pixel = out[projected_count_++];
    if (pinhole) {
      pixel.x() = camera.fx * (p.x() / p.z()) + camera.cx;
      pixel.y() = camera.fy * (p.y() / p.z()) + camera.cy;
    } else {
      pixel = camera.projectCameraPoint(p);
    }
    return true;
  };
  if (shape.type == ShapeType::kTruncatedCone) {
    const Eigen::Vector3d axis = rot * shape.axis;
    const Eigen::Vector3d u = axis.unitOrthogonal();
    const Eigen::Vector3d v = axis.cross(u);
    const Eigen::Vector3d far_end = origin + axis * shape.length;
#if defined(__SSE2__)
    if (pinhole) {
      // x and y in the two lanes, z alone: per coordinate the same products and sums as below
      // (cos * u + sin * v, end + radius * dir, f * (x / z) + c), so the same pixels.
      const __m128d u_xy = _mm_loadu_pd(u.data()), v_xy = _mm_loadu_pd(v.data());
      const __m128d ends_xy[2] = {_mm_loadu_pd(origin.data()), _mm_loadu_pd(far_end.data())};
      const double ends_z[2] = {origin.z(), far_end.z()};
      const double radii[2] = {shape.radius_start, shape.radius_end};
      const __m128d focal = _mm_set_pd(camera.fy, camera.fx);
      const __m128d principal = _mm_set_pd(camera.cy, camera.cx);
      for (int i = 0; i < n; ++i) {
        const __m128d c = _mm_set1_pd(cos_[i]), s = _mm_set1_pd(sin_[i]);
        const __m128d dir_xy = _mm_add_pd(_mm_mul_pd(c, u_xy), _mm_mul_pd(s, v_xy));
        const double dir_z = cos_[i] * u.z() + sin_[i] * v.z();
        for (int end = 0; end < 2; ++end) {
          const double z = ends_z[end] + radii[end] * dir_z;
          if (z < CameraModel::kMinDepth) return false;
          const __m128d xy = _mm_add_pd(ends_xy[end], _mm_mul_pd(_mm_set1_pd(radii[end]), dir_xy));
          _mm_storeu_pd(out[projected_count_++].data(),
                        _mm_add_pd(_mm_mul_pd(focal, _mm_div_pd(xy, _mm_set1_pd(z))), principal));
        }
      }
      return true;
    }
#endif
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d dir = cos_[i] * u + sin_[i] * v;
      if (!emit(origin + shape.radius_start * dir) || !emit(far_end + shape.radius_end * dir))
        return false;
    }
    return true;
  }
  if (shape.type == ShapeType::kEllipsoid) {
    // In the frame where the ellipsoid is the unit sphere, the contour seen from the camera centre
    // o is the circle {u : u.o = 1}: centre o/|o|^2, radius sqrt(1 - 1/|o|^2), normal o.
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

namespace {

// Andrew's monotone chain over raw arrays (the rasterizer's hot path): sorts `points` by (x, y),
// writes the hull to `hull` (room for 2n) and returns its size. n < 3 copies the points unsorted.
int monotoneChain(Eigen::Vector2d* points, int n, Eigen::Vector2d* hull) {
  if (n < 3) {
    std::copy(points, points + n, hull);
    return n;
  }
  // Insertion sort: a few dozen points, no comparator calls. Equal points are interchangeable, so
  // any correct sort gives the same hull.
  for (int i = 1; i < n; ++i) {
    const Eigen::Vector2d p = points[i];
    int j = i;
    for (; j > 0 &&
           (p.x() < points[j - 1].x() || (p.x() == points[j - 1].x() && p.y() < points[j - 1].y()));
         --j)
      points[j] = points[j - 1];
    points[j] = p;
  }
#if defined(__SSE2__)
  // The same subtractions and products with x and y in the two lanes, so the same value.
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const __m128d origin = _mm_loadu_pd(o.data());
    const __m128d oa = _mm_sub_pd(_mm_loadu_pd(a.data()), origin);
    const __m128d ob = _mm_sub_pd(_mm_loadu_pd(b.data()), origin);
    const __m128d products = _mm_mul_pd(oa, _mm_shuffle_pd(ob, ob, 1));  // oa.x ob.y, oa.y ob.x
    return _mm_cvtsd_f64(_mm_sub_sd(products, _mm_unpackhi_pd(products, products)));
  };
#else
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
#endif
  int k = 0;
  for (int i = 0; i < n; ++i) {  // lower chain
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (int i = n - 1, lower = k + 1; i-- > 0;) {  // upper chain
    while (k >= lower && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  return k - 1;
}

}  // namespace

void convexHull(std::vector<Eigen::Vector2d>& points, std::vector<Eigen::Vector2d>& hull) {
  const int n = static_cast<int>(points.size());
  hull.resize(2 * points.size());
  hull.resize(monotoneChain(points.data(), n, hull.data()));
}

namespace {

// Tracks first/last non-empty rows and the column range while spans are written.
struct SpanBox {
  int xmin, xmax;
  int first = -1, last = -1;
  void add(int y, int x0, int x1) {
    if (x1 > x0) {
      if (first < 0) first = y;
      last = y;
      xmin = std::min(xmin, x0);
      xmax = std::max(xmax, x1);
    }
  }
};

// Rows whose centre lies in [p.y, q.y), clipped to the image rows [y0, y1).
inline std::pair<int, int> rowsCrossed(const Eigen::Vector2d& p, const Eigen::Vector2d& q, int y0,
                                       int y1) {
  return std::pair{std::max(y0, ceilToInt(std::max(p.y(), 0.0))),
                   std::min(y1, ceilToInt(std::clamp(q.y(), 0.0, double(y1))))};
}

// Whether y never decreases along either chain from the top vertex to the bottom one.
inline bool chainsAreMonotone(const Eigen::Vector2d* hull, int n, int top, int bottom) {
  bool monotone = true;
  for (int v = top; v != bottom && monotone;) {
    const int to = v + 1 == n ? 0 : v + 1;
    monotone = hull[to].y() >= hull[v].y();
    v = to;
  }
  for (int v = top; v != bottom && monotone;) {
    const int to = v == 0 ? n - 1 : v - 1;
    monotone = hull[to].y() >= hull[v].y();
    v = to;
  }
  return monotone;
}

// One chain of the hull from the top vertex towards the bottom one (step 1 forward, n - 1
// backward): the x where its current edge crosses the current row, and the row that edge ends at.
struct HullChain {
  int v, step;
  int end_row = 0;
  double x = 0, slope = 0;
};

struct ChainWalker {
  const Eigen::Vector2d* hull;
  int n, bottom, y0, y1;

  // Moves `c` to the edge that covers row y (the one starting there) and returns false if there is
  // none, which monotone chains rule out.
  bool advance(HullChain& c, int y) const {
    while (c.v != bottom) {
      const int to = c.v + c.step < n ? c.v + c.step : c.v + c.step - n;  // no division
      const Eigen::Vector2d& p = hull[c.v];
      const Eigen::Vector2d& q = hull[to];
      c.v = to;
      const auto [from_row, to_row] = rowsCrossed(p, q, y0, y1);
      if (to_row > from_row) {
        if (from_row != y) return false;
        c.slope = (q.x() - p.x()) / (q.y() - p.y());
        c.x = p.x() + c.slope * (from_row - p.y());
        c.end_row = to_row;
        return true;
      }
    }
    return false;
  }
};

// Rows [y, end) of a hull that may reach past the image: clamped first, so the integer conversion
// is safe for any projection.
inline void fillClampedRows(HullChain& a, HullChain& b, int& y, int end, double width, RowSpan* out,
                            SpanBox& box) {
  double xa = a.x, xb = b.x;
  for (; y < end; ++y, xa += a.slope, xb += b.slope) {
    const double left = std::clamp(std::min(xa, xb), 0.0, width);
    const double right = std::clamp(std::max(xa, xb), left, width);
    const int x0 = ceilToInt(left);
    const int x1 = ceilToInt(right);
    out[y] = {static_cast<int16_t>(x0), static_cast<int16_t>(x1)};
    box.add(y, x0, x1);
  }
  a.x = xa;
  b.x = xb;
}

#if defined(__SSE2__)
// Rows of a hull well inside the image run two lanes (the chains) at once: the same adds, min/max
// and truncation as the scalar code, so the same spans. The box is accumulated over all rows and
// redone by a scalar pass only if some row is empty.
struct LaneSpanBox {
  __m128i span_min = _mm_set1_epi16(INT16_MAX), span_max = _mm_set1_epi16(INT16_MIN);
  __m128i all_nonempty = _mm_set1_epi16(-1);

  void resolve(const RowSpan* out, int y0, int y1, SpanBox& box) const {
    if ((_mm_extract_epi16(all_nonempty, 0) & 1) != 0) {
      box.first = y0;
      box.last = y1 - 1;
      box.xmin = static_cast<int16_t>(_mm_extract_epi16(span_min, 0));
      box.xmax = static_cast<int16_t>(_mm_extract_epi16(span_max, 1));
    } else {
      for (int y = y0; y < y1; ++y) box.add(y, out[y].x0, out[y].x1);
    }
  }
};

inline void fillInsideRows(HullChain& a, HullChain& b, int& y, int end, RowSpan* out,
                           LaneSpanBox& lanes) {
  __m128d x = _mm_set_pd(b.x, a.x);
  const __m128d step = _mm_set_pd(b.slope, a.slope);
  for (; y < end; ++y, x = _mm_add_pd(x, step)) {
    const __m128d swapped = _mm_shuffle_pd(x, x, 1);
    const __m128d lo_hi = _mm_unpacklo_pd(_mm_min_sd(x, swapped), _mm_max_sd(x, swapped));
    const __m128i truncated = _mm_cvttpd_epi32(lo_hi);
    const __m128d above = _mm_cmpgt_pd(lo_hi, _mm_cvtepi32_pd(truncated));
    const __m128i ceiled = _mm_sub_epi32(
        truncated, _mm_shuffle_epi32(_mm_castpd_si128(above), _MM_SHUFFLE(3, 3, 2, 0)));
    const __m128i span = _mm_packs_epi32(ceiled, ceiled);  // int16 lanes: x0, x1, ...
    const int32_t packed = _mm_cvtsi128_si32(span);
    std::memcpy(static_cast<void*>(&out[y]), &packed, sizeof(RowSpan));  // x0 low, x1 high
    lanes.span_min = _mm_min_epi16(lanes.span_min, span);
    lanes.span_max = _mm_max_epi16(lanes.span_max, span);
    lanes.all_nonempty =
        _mm_and_si128(lanes.all_nonempty, _mm_cmpgt_epi16(_mm_srli_epi32(span, 16), span));
  }
  a.x = _mm_cvtsd_f64(x);
  b.x = _mm_cvtsd_f64(_mm_unpackhi_pd(x, x));
}
#else
// Rows of a hull well inside the image need no clamping.
inline void fillInsideRows(HullChain& a, HullChain& b, int& y, int end, RowSpan* out,
                           SpanBox& box) {
  double xa = a.x, xb = b.x;
  for (; y < end; ++y, xa += a.slope, xb += b.slope) {
    const int x0 = ceilToInt(std::min(xa, xb));
    const int x1 = ceilToInt(std::max(xa, xb));
    out[y] = {static_cast<int16_t>(x0), static_cast<int16_t>(x1)};
    box.add(y, x0, x1);
  }
  a.x = xa;
  b.x = xb;
}
#endif

}  // namespace

Footprint ShapeRasterizer::scanConvexHull(const CameraModel& camera, RowSpan* buffer) {
  Footprint f;
  const int n = static_cast<int>(hull_.size());
  if (n < 3) return f;
  int top = 0, bottom = 0;
  double hull_xmin = hull_[0].x(), hull_xmax = hull_[0].x();
  for (int i = 1; i < n; ++i) {
    if (hull_[i].y() < hull_[top].y()) top = i;
    if (hull_[i].y() > hull_[bottom].y()) bottom = i;
    hull_xmin = std::min(hull_xmin, hull_[i].x());
    hull_xmax = std::max(hull_xmax, hull_[i].x());
  }
  // Rows whose centre lies in [ytop, ybottom), top-left rule.
  const int y0 = std::max(0, static_cast<int>(std::ceil(hull_[top].y())));
  const int y1 =
      std::min({camera.height, kMaxImageRows, static_cast<int>(std::ceil(hull_[bottom].y()))});
  if (y0 >= y1) return f;

  // Each chain from the top vertex to the bottom vertex (one forward, one backward) gives an x for
  // every row its edges cross, stepping by the edge's slope; a row takes the smaller as left and
  // the larger as right edge. When y never decreases along either chain (a convex hull, barring
  // rounding), the chains' row ranges tile [y0, y1) in order, so both chains can be walked
  // together row by row. Otherwise a later edge may overwrite rows, which only the per-chain
  // arrays reproduce.
  if (!chainsAreMonotone(hull_.data(), n, top, bottom)) {
    return scanChains(camera, y0, y1, top, bottom, buffer);
  }
  const ChainWalker walker{hull_.data(), n, bottom, y0, y1};
  HullChain a{top, 1}, b{top, n - 1};
  if (!walker.advance(a, y0) || !walker.advance(b, y0)) {
    return scanChains(camera, y0, y1, top, bottom, buffer);
  }
  SpanBox box{camera.width, 0};
  // Clamping to the image is a no-op when the hull lies well inside it (the walked x stay within
  // rounding of the hull's x range).
  const bool inside = hull_xmin >= 1 && hull_xmax <= camera.width - 1;
  const double width = camera.width;
  RowSpan* out = buffer - y0;
#if defined(__SSE2__)
  LaneSpanBox lanes;
#endif
  for (int y = y0;;) {
    const int end = std::min(a.end_row, b.end_row);
    if (inside) {
#if defined(__SSE2__)
      fillInsideRows(a, b, y, end, out, lanes);
#else
      fillInsideRows(a, b, y, end, out, box);
#endif
    } else {
      fillClampedRows(a, b, y, end, width, out, box);
    }
    if (y >= y1) break;
    if ((y == a.end_row && !walker.advance(a, y)) || (y == b.end_row && !walker.advance(b, y)))
      return scanChains(camera, y0, y1, top, bottom, buffer);
  }
#if defined(__SSE2__)
  if (inside) lanes.resolve(out, y0, y1, box);
#endif
  return trim(buffer, y0, box.first, box.last, box.xmin, box.xmax);
}

Footprint ShapeRasterizer::scanChains(const CameraModel& camera, int y0, int y1, int top,
                                      int bottom, RowSpan* buffer) {
  const int n = static_cast<int>(hull_.size());
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
  SpanBox box{camera.width, 0};
  for (int r = 0; r < rows; ++r) {
    // Clamped first, so the integer conversion is safe for any projection.
    const double left = std::clamp(std::min(xa[r], xb[r]), 0.0, width);
    const double right = std::clamp(std::max(xa[r], xb[r]), left, width);
    const int x0 = ceilToInt(left);
    const int x1 = ceilToInt(right);
    buffer[r] = {static_cast<int16_t>(x0), static_cast<int16_t>(x1)};
    box.add(y0 + r, x0, x1);
  }
  return trim(buffer, y0, box.first, box.last, box.xmin, box.xmax);
}

Footprint ShapeRasterizer::trim(RowSpan* buffer, int y0, int first, int last, int xmin, int xmax) {
  Footprint f;
  if (first < 0) return f;
  // Empty rows at both ends are dropped so the box is tight; spans stay relative to the new y0.
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
  hull_.resize(2 * projected_count_);
  hull_.resize(monotoneChain(projected_.data(), projected_count_, hull_.data()));
  return scanConvexHull(camera, buffer);
}

}  // namespace mocap
