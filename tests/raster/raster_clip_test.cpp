// Properties: near-plane clipping, guard band, back-face culling, invalid input.
//  * Conformance: on every unambiguous pixel (centre ≥ unambiguous_margin() from the
//    outline of the exactly clipped and projected polygon, lib/vgeo/raster/raster_model.h:
//    double, no guard band, no fixed point), coverage equals the exact model, and the
//    depth matches the exact affine depth within the snapping tolerance (spec/raster.md).
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
#include "vgeo/raster/raster_model.h"

namespace vgeo {
namespace {

using raster_test::raster_tris;
using raster_test::Tri;
using raster_test::uniform;

void check_conformance(const Tri& t, const Mat4& m, double z_near, uint32_t w, uint32_t h, RasterPath path) {
  RasterOptions opt;
  opt.z_near = float(z_near);
  opt.cull_backfaces = false;
  opt.path = path;
  VisBuffer buf;
  buf.resize(w, h);
  raster_tris(buf, {t}, m, 5, opt);
  ModelPolygon poly = model_polygon(t.v, m, z_near, w, h);
  const double margin = unambiguous_margin(poly);
  double area2 = 0;
  for (uint32_t i = 0; i < poly.count; ++i) {
    uint32_t j = (i + 1) % poly.count;
    area2 += poly.x[i] * poly.y[j] - poly.x[j] * poly.y[i];
  }
  // Depth plane of the exact polygon from its best-conditioned fan triangle.
  bool check_depth = false;
  double da = 0, db = 0;
  double zmin = 1, zmax = 0;
  for (uint32_t i = 0; i < poly.count; ++i) zmin = std::min(zmin, poly.depth[i]), zmax = std::max(zmax, poly.depth[i]);
  if (poly.count >= 3 && std::abs(area2) > 2.0) {
    uint32_t best = 1;
    double best_area = 0;
    for (uint32_t k = 1; k + 1 < poly.count; ++k) {
      double a = std::abs((poly.x[k] - poly.x[0]) * (poly.y[k + 1] - poly.y[0]) -
                          (poly.x[k + 1] - poly.x[0]) * (poly.y[k] - poly.y[0]));
      if (a > best_area) best_area = a, best = k;
    }
    uint32_t i1 = best, i2 = best + 1;
    double a2 = (poly.x[i1] - poly.x[0]) * (poly.y[i2] - poly.y[0]) - (poly.x[i2] - poly.x[0]) * (poly.y[i1] - poly.y[0]);
    check_depth = std::abs(a2) > 2.0;
    if (check_depth) {
      double dz1 = poly.depth[i1] - poly.depth[0], dz2 = poly.depth[i2] - poly.depth[0];
      da = (dz1 * (poly.y[i2] - poly.y[0]) - dz2 * (poly.y[i1] - poly.y[0])) / a2;
      db = (dz2 * (poly.x[i1] - poly.x[0]) - dz1 * (poly.x[i2] - poly.x[0])) / a2;
    }
  }
  for (uint32_t py = 0; py < h; ++py)
    for (uint32_t px = 0; px < w; ++px) {
      uint64_t key = buf.keys[size_t(py) * w + px];
      double cx = px + 0.5, cy = py + 0.5;
      int expected = int(model_coverage(poly, cx, cy, margin));
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
        double exact = poly.depth[0] + da * (cx - poly.x[0]) + db * (cy - poly.y[0]);
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

// Found by the conformance property (max_success=3000): denormal vertex depths.
TEST(RasterClip, DenormalVertexDepthsClampToFltMin) {
  const uint32_t w = 16, h = 16;
  const float tiny = std::ldexp(1.0f, -140);
  Tri t{{{1, 1, tiny}, {1, 15, tiny}, {15, 1, 0.0f}}};
  VisBuffer buf;
  buf.resize(w, h);
  RasterStats s = raster_tris(buf, {t}, raster_test::pixel_to_clip(w, h), 1, RasterOptions{});
  EXPECT_GT(s.pixels_written, 0u);
  for (uint64_t k : buf.keys) {
    if (k) {
      EXPECT_EQ(vis_key_depth(k), std::numeric_limits<float>::min());
    }
  }
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

namespace vgeo {
namespace {

// The model itself: known points, and it must flag a rasterization shifted by one pixel.
TEST(RasterModel, ClassifiesKnownPointsAndDetectsShiftedCoverage) {
  const uint32_t w = 32, h = 32;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  Vec3 v[3] = {{2, 2, 0.5f}, {2, 30, 0.5f}, {30, 2, 0.5f}};
  ModelPolygon p = model_polygon(v, m, 0.01, w, h);
  ASSERT_EQ(p.count, 3u);
  double margin = unambiguous_margin(p);
  EXPECT_NEAR(margin, 1.0 / 64 + 30.0 / (1 << 18), 1e-12);
  EXPECT_EQ(model_coverage(p, 5.5, 5.5, margin), ModelCoverage::kInside);
  EXPECT_EQ(model_coverage(p, 1.5, 5.5, margin), ModelCoverage::kOutside);
  EXPECT_EQ(model_coverage(p, 2.0, 5.5, margin), ModelCoverage::kAmbiguous);  // on the left edge
  EXPECT_EQ(model_coverage(p, 16.0, 16.0, margin), ModelCoverage::kAmbiguous);  // on the hypotenuse
  EXPECT_EQ(model_coverage(p, 20.5, 20.5, margin), ModelCoverage::kOutside);

  VisBuffer buf;
  buf.resize(w, h);
  raster_tris(buf, {Tri{{v[0], v[1], v[2]}}}, m, 1, RasterOptions{});
  int compared = 0, disagree = 0, shifted_disagree = 0;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      ModelCoverage c = model_coverage(p, x + 0.5, y + 0.5, margin);
      if (c == ModelCoverage::kAmbiguous) continue;
      bool in = c == ModelCoverage::kInside;
      ++compared;
      disagree += in != (buf.keys[y * w + x] != 0);
      bool shifted = x > 0 && buf.keys[y * w + x - 1] != 0;  // a rasterizer off by one pixel
      shifted_disagree += in != shifted;
    }
  EXPECT_GT(compared, int(w * h) * 9 / 10);
  EXPECT_EQ(disagree, 0);
  EXPECT_GT(shifted_disagree, 20);
}

// Non-finite input: the model is empty (matches the rasterizer dropping the triangle).
TEST(RasterModel, NonFiniteTriangleIsEmpty) {
  Vec3 v[3] = {{std::numeric_limits<float>::quiet_NaN(), 0, 0.5f}, {0, 1, 0.5f}, {1, 0, 0.5f}};
  ModelPolygon p = model_polygon(v, Mat4{}, 0.01, 8, 8);
  EXPECT_EQ(p.count, 0u);
  EXPECT_EQ(model_coverage(p, 4, 4, unambiguous_margin(p)), ModelCoverage::kOutside);
}

}  // namespace
}  // namespace vgeo
