// Properties: near-plane clipping, guard band, back-face culling, invalid input.
//  * Conformance: on every unambiguous pixel (centre ≥ kUnambiguousMargin from each edge
//    of the exactly clipped and projected polygon, computed independently in double
//    without guard band or fixed point), coverage equals the exact model, and the depth
//    matches the exact affine depth within the snapping tolerance (spec/raster.md).
//  * Written depths are always in (0, 1], finite, never −0; a triangle behind the camera
//    writes nothing; vertices at the eye or exactly on the near plane produce no NaN.
//  * NaN/Inf input is dropped and counted, never reaches a float→int conversion.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <array>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "raster_testing.h"

namespace vgeo {
namespace {

using raster_test::raster_tris;
using raster_test::Tri;
using raster_test::uniform;

// spec/raster.md "Comparing implementations": 4 sub-pixel units (1/64 px).
constexpr double kUnambiguousMargin = 4.0 / 256.0;

struct Pt {
  double x, y, depth;
};

// Exact-model screen polygon of a triangle: clip space in double, clipped against
// w ≥ z_near only, projected without snapping.
std::vector<Pt> model_polygon(const Tri& t, const Mat4& m, double z_near, uint32_t w, uint32_t h) {
  struct C {
    double v[4];
  };
  std::vector<C> poly;
  for (const Vec3& p : t.v) {
    C c;
    for (int r = 0; r < 4; ++r)
      c.v[r] = double(m.at(r, 0)) * p.x + double(m.at(r, 1)) * p.y + double(m.at(r, 2)) * p.z + m.at(r, 3);
    poly.push_back(c);
  }
  std::vector<C> out;
  for (size_t i = 0; i < poly.size(); ++i) {
    const C& a = poly[i];
    const C& b = poly[(i + 1) % poly.size()];
    double da = a.v[3] - z_near, db = b.v[3] - z_near;
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) {
      double s = da / (da - db);
      C c;
      for (int k = 0; k < 4; ++k) c.v[k] = a.v[k] + s * (b.v[k] - a.v[k]);
      out.push_back(c);
    }
  }
  std::vector<Pt> screen;
  for (const C& c : out)
    screen.push_back({(c.v[0] / c.v[3] * 0.5 + 0.5) * w, (0.5 - c.v[1] / c.v[3] * 0.5) * h, c.v[2] / c.v[3]});
  return screen;
}

double polygon_area2(const std::vector<Pt>& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Pt& u = p[i];
    const Pt& v = p[(i + 1) % p.size()];
    a += u.x * v.y - v.x * u.y;
  }
  return a;
}

// +1 unambiguously inside, −1 unambiguously outside, 0 ambiguous: the centre is closer
// than kUnambiguousMargin to the polygon outline (Euclidean distance to the segments, so
// degenerate and sliver polygons are handled without any edge orientation).
int classify(const std::vector<Pt>& p, double x, double y) {
  if (p.size() < 3) return -1;
  double min_dist = std::numeric_limits<double>::infinity();
  int winding = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Pt& a = p[i];
    const Pt& b = p[(i + 1) % p.size()];
    double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? std::clamp(((x - a.x) * dx + (y - a.y) * dy) / len2, 0.0, 1.0) : 0.0;
    min_dist = std::min(min_dist, std::hypot(a.x + t * dx - x, a.y + t * dy - y));
    // Crossing of the ray to +x (half-open in y), signed by direction.
    if ((a.y <= y) != (b.y <= y)) {
      double xc = a.x + (y - a.y) / (b.y - a.y) * dx;
      if (xc > x) winding += (b.y > a.y) ? 1 : -1;
    }
  }
  if (min_dist < kUnambiguousMargin) return 0;
  return winding != 0 ? 1 : -1;
}

void check_conformance(const Tri& t, const Mat4& m, double z_near, uint32_t w, uint32_t h, RasterPath path) {
  RasterOptions opt;
  opt.z_near = float(z_near);
  opt.cull_backfaces = false;
  opt.path = path;
  VisBuffer buf;
  buf.resize(w, h);
  raster_tris(buf, {t}, m, 5, opt);
  std::vector<Pt> poly = model_polygon(t, m, z_near, w, h);
  double area2 = poly.size() >= 3 ? polygon_area2(poly) : 0.0;
  // Depth plane of the exact polygon (for polygons large enough to define it well).
  bool check_depth = std::abs(area2) > 2.0;
  double da = 0, db = 0;
  double zmin = 1, zmax = 0;
  for (const Pt& p : poly) zmin = std::min(zmin, p.depth), zmax = std::max(zmax, p.depth);
  if (check_depth) {
    // Least-structured choice: the fan triangle (0, k, k+1) with the largest area.
    size_t best = 1;
    double best_area = 0;
    for (size_t k = 1; k + 1 < poly.size(); ++k) {
      double a = std::abs((poly[k].x - poly[0].x) * (poly[k + 1].y - poly[0].y) -
                          (poly[k + 1].x - poly[0].x) * (poly[k].y - poly[0].y));
      if (a > best_area) best_area = a, best = k;
    }
    const Pt &p0 = poly[0], &p1 = poly[best], &p2 = poly[best + 1];
    double a2 = (p1.x - p0.x) * (p2.y - p0.y) - (p2.x - p0.x) * (p1.y - p0.y);
    check_depth = std::abs(a2) > 2.0;
    if (check_depth) {
      da = ((p1.depth - p0.depth) * (p2.y - p0.y) - (p2.depth - p0.depth) * (p1.y - p0.y)) / a2;
      db = ((p2.depth - p0.depth) * (p1.x - p0.x) - (p1.depth - p0.depth) * (p2.x - p0.x)) / a2;
    }
  }
  for (uint32_t py = 0; py < h; ++py)
    for (uint32_t px = 0; px < w; ++px) {
      uint64_t key = buf.keys[size_t(py) * w + px];
      double cx = px + 0.5, cy = py + 0.5;
      int expected = classify(poly, cx, cy);
      if (expected != 0 && (expected > 0) != (key != 0))
        RC_LOG() << "pixel (" << px << ", " << py << ") raster " << (key != 0) << " model " << expected
                 << " path " << int(path) << " tri " << raster_test::describe(t) << "\n";
      RC_ASSERT(expected == 0 || (expected > 0) == (key != 0));
      if (key == 0) continue;
      float d = vis_key_depth(key);
      RC_ASSERT(std::isfinite(d));
      RC_ASSERT(d > 0.0f);
      RC_ASSERT(d <= 1.0f);
      // Within the vertex depth range (up to rounding) — no extrapolated garbage.
      RC_ASSERT(double(d) >= zmin * (1 - 1e-5) - 1e-30 || d == std::numeric_limits<float>::min());
      RC_ASSERT(double(d) <= zmax * (1 + 1e-5) || d == std::numeric_limits<float>::min());
      if (check_depth && expected > 0) {
        double exact = poly[0].depth + da * (cx - poly[0].x) + db * (cy - poly[0].y);
        // Snapping moves a vertex by ≤ 1/512 px per axis: allow 2/256 px of gradient.
        double tol = 1e-6 * zmax + (std::abs(da) + std::abs(db)) * (2.0 / 256.0) + 1e-7;
        if (std::abs(d - exact) > tol)
          RC_LOG() << "depth " << d << " exact " << exact << " tol " << tol << " at (" << px << ", " << py << ")\n";
        RC_ASSERT(std::abs(double(d) - exact) <= tol);
      }
    }
}

RC_GTEST_PROP(RasterClip, PerspectiveCoverageMatchesExactModelOnUnambiguousPixels, ()) {
  const uint32_t w = 48, h = 40;
  double z_near = *rc::gen::element(0.01, 0.1, 0.5);
  Mat4 m = to_float(perspective_reversed_z(1.1, double(w) / h, z_near));
  Tri t = raster_test::view_triangle(float(z_near));
  for (RasterPath path : {RasterPath::kReference, RasterPath::kAuto})
    check_conformance(t, m, double(float(z_near)), w, h, path);
}

RC_GTEST_PROP(RasterClip, PixelSpaceCoverageMatchesExactModelOnUnambiguousPixels, ()) {
  const uint32_t w = 40, h = 40;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  Tri t = raster_test::pixel_triangle(int(w), int(h));
  check_conformance(t, m, double(0.01f), w, h, RasterPath::kAuto);
}

TEST(RasterClip, TriangleBehindCameraWritesNothing) {
  const uint32_t w = 32, h = 32;
  Mat4 m = to_float(perspective_reversed_z(1.0, 1.0, 0.1));
  // Behind the eye (+Z) and between the eye and the near plane.
  for (float z : {1.0f, 0.05f, 1e-30f, 0.0f, -0.0999f}) {
    Tri t{{{-1, -1, z}, {1, -1, z}, {0, 1, z}}};
    VisBuffer buf;
    buf.resize(w, h);
    RasterOptions opt;
    opt.z_near = 0.1f;
    opt.cull_backfaces = false;
    RasterStats s = raster_tris(buf, {t}, m, 1, opt);
    EXPECT_EQ(s.pixels_written, 0u) << z;
    EXPECT_EQ(s.triangles_culled, 1u) << z;
    for (uint64_t k : buf.keys) EXPECT_EQ(k, 0u);
  }
}

TEST(RasterClip, FloorCrossingNearPlaneStaysBelowHorizon) {
  // A huge floor triangle reaching behind the camera: unclipped, its vertices behind the
  // eye would project above the horizon (full-screen garbage).
  const uint32_t w = 64, h = 64;
  Mat4 m = to_float(perspective_reversed_z(1.2, 1.0, 0.05));
  Tri t{{{-100, -1, 50}, {100, -1, 50}, {0, -1, -100}}};  // y = −1 plane, both sides of the eye
  for (RasterPath path : {RasterPath::kReference, RasterPath::kMicropoly, RasterPath::kScanline}) {
    VisBuffer buf;
    buf.resize(w, h);
    RasterOptions opt;
    opt.z_near = 0.05f;
    opt.cull_backfaces = false;
    opt.path = path;
    RasterStats s = raster_tris(buf, {t}, m, 1, opt);
    EXPECT_EQ(s.triangles_clipped, 1u);
    EXPECT_GT(s.pixels_written, 0u);
    for (uint32_t y = 0; y < h / 2; ++y)
      for (uint32_t x = 0; x < w; ++x) EXPECT_EQ(buf.keys[y * w + x], 0u) << x << "," << y;
    for (uint64_t k : buf.keys)
      if (k) {
        EXPECT_LE(vis_key_depth(k), 1.0f);
      }
  }
}

TEST(RasterClip, VertexAtEyeAndOnNearPlaneGiveFiniteDepths) {
  const uint32_t w = 32, h = 32;
  const float z_near = 0.25f;
  Mat4 m = to_float(perspective_reversed_z(1.0, 1.0, z_near));
  std::vector<Tri> tris = {
      Tri{{{0, 0, 0}, {1, -1, -2}, {-1, 1, -2}}},                 // vertex at the eye
      Tri{{{0, 0, -z_near}, {1, -1, -2}, {-1, 1, -2}}},           // vertex exactly on the near plane
      Tri{{{-1, -1, -z_near}, {1, -1, -z_near}, {0, 1, -z_near}}},  // whole triangle on it
      Tri{{{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}},                     // all at the eye
  };
  RasterOptions opt;
  opt.z_near = z_near;
  opt.cull_backfaces = false;
  VisBuffer buf;
  buf.resize(w, h);
  RasterStats s = raster_tris(buf, tris, m, 1, opt);
  EXPECT_GT(s.pixels_written, 0u);
  bool saw_one = false;
  for (uint64_t k : buf.keys) {
    if (!k) continue;
    float d = vis_key_depth(k);
    EXPECT_TRUE(std::isfinite(d));
    EXPECT_GT(d, 0.0f);
    EXPECT_LE(d, 1.0f);
    saw_one |= d == 1.0f;
  }
  EXPECT_TRUE(saw_one);  // the triangle on the near plane writes depth exactly 1
}

TEST(RasterCull, BackFacesCulledOnlyWhenEnabled) {
  const uint32_t w = 16, h = 16;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  Tri front{{{1, 1, 0.5f}, {1, 15, 0.25f}, {15, 1, 0.75f}}};  // counter-clockwise in NDC
  Tri back{{front.v[0], front.v[2], front.v[1]}};
  for (RasterPath path : {RasterPath::kReference, RasterPath::kMicropoly, RasterPath::kScanline}) {
    RasterOptions opt;
    opt.path = path;
    VisBuffer a, b, c;
    a.resize(w, h);
    b.resize(w, h);
    c.resize(w, h);
    RasterStats sf = raster_tris(a, {front}, m, 1, opt);
    RasterStats sb = raster_tris(b, {back}, m, 1, opt);
    EXPECT_GT(sf.pixels_written, 0u);
    EXPECT_EQ(sf.triangles_culled, 0u);
    EXPECT_EQ(sb.pixels_written, 0u);
    EXPECT_EQ(sb.triangles_culled, 1u);
    opt.cull_backfaces = false;
    raster_tris(c, {back}, m, 1, opt);
    // Same vertex set, same first vertex: identical coverage and bit-identical keys.
    EXPECT_EQ(raster_test::first_mismatch(a, c), -1);
  }
}

TEST(RasterInvalid, NonFiniteVerticesAreDroppedAndCounted) {
  const uint32_t w = 16, h = 16;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const float big = std::numeric_limits<float>::max();
  std::vector<Tri> tris = {
      Tri{{{nan, 1, 0.5f}, {1, 15, 0.5f}, {15, 1, 0.5f}}},
      Tri{{{1, 1, 0.5f}, {inf, 15, 0.5f}, {15, 1, 0.5f}}},
      Tri{{{1, 1, 0.5f}, {1, 15, 0.5f}, {15, -inf, 0.5f}}},
      Tri{{{1, 1, nan}, {1, 15, 0.5f}, {15, 1, 0.5f}}},
      Tri{{{-big, -big, 0.5f}, {-big, big, 0.5f}, {big, -big, 0.5f}}},  // finite, huge
      Tri{{{1, 1, big}, {1, 15, -big}, {15, 1, 0.5f}}},                  // huge depths: clamped
      Tri{{{1, 1, 0.5f}, {1, 15, 0.5f}, {15, 1, 0.5f}}},
  };
  for (RasterPath path : {RasterPath::kReference, RasterPath::kMicropoly, RasterPath::kScanline,
                          RasterPath::kAuto}) {
    RasterOptions opt;
    opt.path = path;
    VisBuffer buf;
    buf.resize(w, h);
    RasterStats s = raster_tris(buf, tris, m, 1, opt);
    EXPECT_EQ(s.triangles_in, tris.size());
    EXPECT_EQ(s.triangles_invalid, 4u);
    EXPECT_EQ(s.triangles_culled, 4u);
    for (uint64_t k : buf.keys) {
      if (!k) continue;
      EXPECT_GE(vis_key_triangle(k), 4u);
      float d = vis_key_depth(k);
      EXPECT_TRUE(std::isfinite(d) && d > 0 && d <= 1) << d;
    }
  }
  // A matrix with NaN invalidates every triangle.
  Mat4 bad = m;
  bad.at(3, 3) = nan;
  VisBuffer buf;
  buf.resize(w, h);
  RasterStats s = raster_tris(buf, tris, bad, 1, RasterOptions{});
  EXPECT_EQ(s.triangles_invalid, tris.size());
  EXPECT_EQ(s.pixels_written, 0u);
}

TEST(RasterInvalid, IndexOutOfRangeIsDroppedAndCounted) {
  VisBuffer buf;
  buf.resize(8, 8);
  float pos[9] = {-1, -1, 0.5f, 1, -1, 0.5f, -1, 1, 0.5f};
  uint8_t idx[6] = {0, 1, 2, 0, 1, 3};
  RasterStats s;
  rasterize_cluster(buf, pos, 3, idx, 2, Mat4{}, 0, RasterOptions{}, &s);
  EXPECT_EQ(s.triangles_in, 2u);
  EXPECT_EQ(s.triangles_invalid, 1u);
  EXPECT_GT(s.pixels_written, 0u);
}

TEST(RasterStatsTest, AutoPicksMicropolyForSmallAndScanlineForLarge) {
  const uint32_t w = 64, h = 64;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  RasterOptions opt;
  VisBuffer buf;
  buf.resize(w, h);
  RasterStats small = raster_tris(buf, {Tri{{{1, 1, 0.5f}, {1, 3, 0.5f}, {3, 1, 0.5f}}}}, m, 0, opt);
  EXPECT_EQ(small.micropoly_triangles, 1u);
  EXPECT_EQ(small.scanline_triangles, 0u);
  RasterStats large = raster_tris(buf, {Tri{{{1, 1, 0.5f}, {1, 60, 0.5f}, {60, 1, 0.5f}}}}, m, 0, opt);
  EXPECT_EQ(large.micropoly_triangles, 0u);
  EXPECT_EQ(large.scanline_triangles, 1u);
  EXPECT_EQ(large.pixels_written, 58u * 59u / 2u);  // centres with x + y < 61, x, y > 1
}

TEST(RasterProjection, ReversedZInfiniteFar) {
  const double z_near = 0.1;
  Mat4d p = perspective_reversed_z(std::numbers::pi / 2, 2.0, z_near);
  auto apply = [&](double x, double y, double z) {
    std::array<double, 4> c{};
    for (int r = 0; r < 4; ++r) c[r] = p.at(r, 0) * x + p.at(r, 1) * y + p.at(r, 2) * z + p.at(r, 3);
    return c;
  };
  auto c = apply(0, 0, -z_near);
  EXPECT_DOUBLE_EQ(c[2] / c[3], 1.0);  // near plane → depth 1
  c = apply(0, 0, -2 * z_near);
  EXPECT_DOUBLE_EQ(c[2] / c[3], 0.5);
  c = apply(0, 0, -1e30);
  EXPECT_GT(c[2] / c[3], 0.0);  // no far plane: depth stays > 0
  c = apply(2, 1, -1);          // fov 90°, aspect 2: the top-right frustum corner at depth 1
  EXPECT_NEAR(c[0] / c[3], 1.0, 1e-12);
  EXPECT_NEAR(c[1] / c[3], 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(c[3], 1.0);
}

}  // namespace
}  // namespace vgeo
