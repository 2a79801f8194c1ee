// HZB occlusion and frustum tests are conservative (spec/scene.md §Occlusion).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>

#include "vgeo/cull/hzb.h"
#include "vgeo/raster/visbuffer.h"

namespace vgeo {
namespace {

struct DepthImage {
  uint32_t w, h;
  std::vector<uint64_t> keys;
};

DepthImage gen_depth_image() {
  DepthImage d;
  d.w = *rc::gen::inRange<uint32_t>(1, 70);
  d.h = *rc::gen::inRange<uint32_t>(1, 50);
  // A few depth levels (incl. background) in rectangles: equal depths and edges common.
  d.keys.assign(size_t(d.w) * d.h, 0);
  float base = *rc::gen::element(0.0f, 0.01f, 0.1f);
  for (size_t p = 0; p < d.keys.size(); ++p)
    if (base > 0) d.keys[p] = pack_vis_key(base, 0, 0);
  int rects = *rc::gen::inRange(0, 6);
  for (int r = 0; r < rects; ++r) {
    uint32_t x0 = *rc::gen::inRange<uint32_t>(0, d.w), y0 = *rc::gen::inRange<uint32_t>(0, d.h);
    uint32_t x1 = *rc::gen::inRange<uint32_t>(x0, d.w), y1 = *rc::gen::inRange<uint32_t>(y0, d.h);
    float depth = *rc::gen::element(0.02f, 0.05f, 0.2f, 0.5f, 1.0f);
    for (uint32_t y = y0; y <= y1 && y < d.h; ++y)
      for (uint32_t x = x0; x <= x1 && x < d.w; ++x) d.keys[size_t(y) * d.w + x] = pack_vis_key(depth, 1, 1);
  }
  return d;
}

Camera camera_for(const DepthImage& d) {
  Camera c;
  c.width = d.w;
  c.height = d.h;
  c.z_near = 0.01;
  c.fov_y = *rc::gen::element(0.3, 1.0, 2.0);
  return c;
}

Sphere gen_view_sphere() {
  Sphere s;
  s.center = {float(*rc::gen::inRange(-40, 40) * 0.05), float(*rc::gen::inRange(-40, 40) * 0.05),
              -float(*rc::gen::inRange(0, 80) * 0.05)};
  s.radius = float(*rc::gen::inRange(1, 20) * 0.02);
  return s;
}

// Points on the sphere's surface (its projection is the projection of the surface).
template <class F>
void for_sphere_points(const Sphere& s, F&& f) {
  const int kRings = 24, kSegments = 48;
  for (int i = 0; i <= kRings; ++i)
    for (int j = 0; j < kSegments; ++j) {
      double th = 3.14159265358979 * i / kRings, ph = 2 * 3.14159265358979 * j / kSegments;
      f(s.center.x + s.radius * std::sin(th) * std::cos(ph), s.center.y + s.radius * std::sin(th) * std::sin(ph),
        s.center.z + s.radius * std::cos(th));
    }
}

RC_GTEST_PROP(Hzb, OccludedSphereIsBehindEveryPixelItCovers, ()) {
  DepthImage d = gen_depth_image();
  ViewParams view = make_view(camera_for(d));
  ThreadPool pool(1);
  Hzb hzb;
  build_hzb(d.keys.data(), d.w, d.h, pool, &hzb);
  Sphere s = gen_view_sphere();
  auto policy = *rc::gen::element(HzbMipPolicy::k4x4, HzbMipPolicy::k2x2, HzbMipPolicy::kFinest);
  bool occ = hzb_occludes(hzb, s, view, policy);
  RC_CLASSIFY(occ, "occluded");
  if (!occ) return;
  for_sphere_points(s, [&](double x, double y, double z) {
    double depth = -z;
    RC_ASSERT(depth > view.z_near);
    double sx = (x / (depth * view.tan_half_x) * 0.5 + 0.5) * d.w;
    double sy = (0.5 - y / (depth * view.tan_half_y) * 0.5) * d.h;
    if (sx < 0 || sy < 0 || sx >= d.w || sy >= d.h) return;
    float pixel = vis_key_depth(d.keys[size_t(sy) * d.w + size_t(sx)]);
    RC_ASSERT(double(pixel) > view.z_near / depth);
  });
}

RC_GTEST_PROP(Hzb, FinerMipPoliciesCullAtLeastAsMuch, ()) {
  DepthImage d = gen_depth_image();
  ViewParams view = make_view(camera_for(d));
  ThreadPool pool(1);
  Hzb hzb;
  build_hzb(d.keys.data(), d.w, d.h, pool, &hzb);
  Sphere s = gen_view_sphere();
  bool c2 = hzb_occludes(hzb, s, view, HzbMipPolicy::k2x2);
  bool c4 = hzb_occludes(hzb, s, view, HzbMipPolicy::k4x4);
  bool cf = hzb_occludes(hzb, s, view, HzbMipPolicy::kFinest);
  RC_ASSERT(!c2 || c4);
  RC_ASSERT(!c4 || cf);
}

RC_GTEST_PROP(Hzb, MipTexelIsTheMinimumOfItsPixels, ()) {
  DepthImage d = gen_depth_image();
  ThreadPool pool(*rc::gen::inRange(1u, 3u));
  Hzb hzb;
  build_hzb(d.keys.data(), d.w, d.h, pool, &hzb);
  RC_ASSERT(hzb.mip_width.back() == 1u && hzb.mip_height.back() == 1u);
  for (size_t k = 0; k < hzb.mips.size(); ++k)
    for (uint32_t y = 0; y < hzb.mip_height[k]; ++y)
      for (uint32_t x = 0; x < hzb.mip_width[k]; ++x) {
        float m = 1e30f;
        for (uint32_t py = y << k; py < std::min(d.h, (y + 1) << k); ++py)
          for (uint32_t px = x << k; px < std::min(d.w, (x + 1) << k); ++px)
            m = std::min(m, vis_key_depth(d.keys[size_t(py) * d.w + px]));
        RC_ASSERT(hzb.mips[k][size_t(y) * hzb.mip_width[k] + x] == m);
      }
}

TEST(Hzb, SpheresReachingTheNearPlaneAreNeverOccluded) {
  DepthImage d{8, 8, std::vector<uint64_t>(64, pack_vis_key(1.0f, 0, 0))};  // a wall at the near plane
  Camera c;
  c.width = c.height = 8;
  c.z_near = 0.01;
  ViewParams view = make_view(c);
  ThreadPool pool(1);
  Hzb hzb;
  build_hzb(d.keys.data(), 8, 8, pool, &hzb);
  Sphere crossing{{0, 0, -0.01f}, 0.5f}, behind_eye{{0, 0, 1}, 0.5f}, far_away{{0, 0, -5}, 0.5f};
  for (auto policy : {HzbMipPolicy::k4x4, HzbMipPolicy::k2x2, HzbMipPolicy::kFinest}) {
    EXPECT_FALSE(hzb_occludes(hzb, crossing, view, policy));
    EXPECT_FALSE(hzb_occludes(hzb, behind_eye, view, policy));
    EXPECT_TRUE(hzb_occludes(hzb, far_away, view, policy));
  }
}

// Deterministic (every run): behind a wall every sphere is occluded; a single background
// pixel anywhere under the sphere's projection must make it visible, under every mip policy.
// Catches a texel loop that skips the last covered row or column of the sphere's rectangle.
TEST(Hzb, EveryPixelUnderTheSphereCanRevealIt) {
  constexpr uint32_t kW = 40, kH = 30;
  Camera c;
  c.width = kW;
  c.height = kH;
  c.z_near = 0.01;
  c.fov_y = 1.0;
  const ViewParams view = make_view(c);
  ThreadPool pool(1);
  const std::vector<uint64_t> wall(size_t(kW) * kH, pack_vis_key(1.0f, 0, 0));  // at the near plane
  const Sphere spheres[] = {{{0.0f, 0.0f, -3.0f}, 0.3f},    {{0.37f, -0.21f, -2.0f}, 0.13f},
                            {{-0.55f, 0.33f, -2.5f}, 0.21f}, {{0.11f, 0.47f, -1.7f}, 0.07f},
                            {{-0.8f, -0.5f, -3.3f}, 0.4f},   {{0.63f, 0.05f, -2.2f}, 0.05f}};
  for (const Sphere& s : spheres) {
    std::vector<uint8_t> covered(size_t(kW) * kH, 0);
    for_sphere_points(s, [&](double x, double y, double z) {
      const double depth = -z;
      const double sx = (x / (depth * view.tan_half_x) * 0.5 + 0.5) * kW;
      const double sy = (0.5 - y / (depth * view.tan_half_y) * 0.5) * kH;
      if (sx < 0 || sy < 0 || sx >= kW || sy >= kH) return;
      covered[size_t(sy) * kW + size_t(sx)] = 1;
    });
    for (auto policy : {HzbMipPolicy::k4x4, HzbMipPolicy::k2x2, HzbMipPolicy::kFinest}) {
      Hzb hzb;
      build_hzb(wall.data(), kW, kH, pool, &hzb);
      ASSERT_TRUE(hzb_occludes(hzb, s, view, policy)) << "sphere r=" << s.radius;
      for (uint32_t p = 0; p < kW * kH; ++p) {
        if (!covered[p]) continue;
        std::vector<uint64_t> holed = wall;
        holed[p] = 0;  // background: nothing in front of the sphere there
        build_hzb(holed.data(), kW, kH, pool, &hzb);
        EXPECT_FALSE(hzb_occludes(hzb, s, view, policy))
            << "pixel (" << p % kW << ", " << p / kW << ") under sphere r=" << s.radius << ", policy "
            << int(policy);
      }
    }
  }
}

RC_GTEST_PROP(Frustum, CulledSphereHasNoPointInsideTheFrustum, ()) {
  Camera c;
  c.width = *rc::gen::element(64u, 100u, 1920u);
  c.height = *rc::gen::element(48u, 100u, 1080u);
  c.fov_y = *rc::gen::element(0.3, 1.0, 2.5);
  c.z_near = *rc::gen::element(1e-3, 0.1);
  ViewParams view = make_view(c);
  Sphere s;
  s.center = {float(*rc::gen::inRange(-40, 40) * 0.1), float(*rc::gen::inRange(-40, 40) * 0.1),
              float(*rc::gen::inRange(-40, 10) * 0.1)};
  s.radius = float(*rc::gen::inRange(0, 20) * 0.1);
  bool out = sphere_outside_frustum(s, view);
  RC_CLASSIFY(out, "culled");
  if (!out) return;
  for_sphere_points(s, [&](double x, double y, double z) {
    double depth = -z;
    bool inside = depth >= view.z_near && std::abs(x) <= depth * view.tan_half_x && std::abs(y) <= depth * view.tan_half_y;
    RC_ASSERT(!inside);
  });
}

TEST(View, LookAtLooksDownMinusZ) {
  Camera c;
  c.position = {1, 2, 3};
  ASSERT_TRUE(look_at_orientation(c.position, {1, 2, -7}, {0, 1, 0}, &c.orientation));
  ViewParams v = make_view(c);
  // The target lies on the view-space −Z axis at distance 10.
  double p[3] = {1, 2, -7}, q[3];
  for (int r = 0; r < 3; ++r)
    q[r] = v.world_to_view.at(r, 0) * p[0] + v.world_to_view.at(r, 1) * p[1] + v.world_to_view.at(r, 2) * p[2] +
           v.world_to_view.at(r, 3);
  EXPECT_NEAR(q[0], 0, 1e-12);
  EXPECT_NEAR(q[1], 0, 1e-12);
  EXPECT_NEAR(q[2], -10, 1e-12);
  std::array<double, 4> o;
  EXPECT_FALSE(look_at_orientation({0, 0, 0}, {0, 5, 0}, {0, 1, 0}, &o));  // parallel to up
  EXPECT_FALSE(look_at_orientation({0, 0, 0}, {0, 0, 0}, {0, 1, 0}, &o));  // zero direction
}

}  // namespace
}  // namespace vgeo
