// Virtual shadow maps (spec/shadow.md): the pages equal a brute-force full-resolution map of the
// same cut at every sampled texel; marking never misses a sampled page; a static scene's second
// frame draws nothing; moving lights and casters invalidate; hard cases stay finite.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <map>

#include "render/render_helpers.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/render/frame.h"
#include "vgeo/shadow/virtual_shadow.h"

namespace vgeo {
namespace {

Light directional(Vec3d d) {
  Light l;
  l.type = LightType::kDirectional;
  double n = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  l.direction = {d.x / n, d.y / n, d.z / n};
  return l;
}
Light spot(Vec3d p, Vec3d d, double cone_degrees) {
  Light l = directional(d);
  l.type = LightType::kSpot;
  l.position = p;
  l.cone_radians = cone_degrees * M_PI / 180;
  return l;
}
Light point(Vec3d p) {
  Light l;
  l.type = LightType::kPoint;
  l.position = p;
  return l;
}

// The primary view's visibility buffer of `scene` (no shading: the shadow steps do not run).
Frame primary_frame(const RenderScene& scene, const Camera& camera, ThreadPool& pool) {
  RenderSettings settings;
  settings.shade = false;
  Frame frame;
  render_frame(FrameInputs{scene, camera, settings, pool, nullptr, false}, &frame);
  return frame;
}

// What check_pages did: texels checked and every kind of failure found.
struct PageCheck {
  uint64_t checked = 0, mismatched = 0, unmarked = 0, wrong_mip = 0, dropped = 0, drawn_not_marked = 0;
  bool ok() const { return mismatched == 0 && unmarked == 0 && wrong_mip == 0 && dropped == 0 && drawn_not_marked == 0; }
};

// Every texel any covered pixel samples is marked, has a slot, and its stored depth equals the
// brute-force map of the same (map, mip) drawn in one pass.
PageCheck check_pages(const RenderScene& scene, const Camera& camera, uint32_t pages_per_side, float tau = 1.0f) {
  ThreadPool pool(3);
  RenderSettings settings;
  settings.shade = false;
  settings.threshold_px = tau;
  Frame primary;
  render_frame(FrameInputs{scene, camera, settings, pool, nullptr, false}, &primary);
  ShadowOptions options;
  options.pages_per_side = pages_per_side;
  options.pool_pages = 1u << 16;  // nothing dropped: every needed page is drawn
  options.threshold_px = tau;
  ShadowFrame frame = make_shadow_frame(scene.lights, shadow_scene_bounds(scene.meshes, scene.instances),
                                        camera.position, options);
  mark_shadow_pages(primary.vis, primary.view, scene.lights, pool, &frame);
  draw_shadow_pages(scene.meshes, scene.instances, scene.lights, pool, &frame, nullptr);
  PageCheck out;
  out.dropped = frame.pages_dropped;
  out.drawn_not_marked = frame.pages_drawn != frame.pages_marked;
  std::map<std::pair<uint32_t, uint32_t>, std::vector<float>> brute;
  const Mat4d view_to_world = rigid_inverse(primary.view.world_to_view);
  for (uint32_t y = 0; y < primary.vis.height; ++y)
    for (uint32_t x = 0; x < primary.vis.width; ++x) {
      uint64_t key = primary.vis.keys[size_t(y) * primary.vis.width + x];
      if (!key) continue;
      double f;
      Vec3d p = shadow_sample_point(primary.view, view_to_world, x, y, vis_key_depth(key), &f);
      for (uint32_t l = 0; l < scene.lights.size(); ++l) {
        ShadowTexel t;
        if (!select_shadow_texel(frame, l, p, f, &t)) continue;
        // One texel ≈ one pixel (spec/shadow.md §4): the texel is no larger than the footprint
        // unless it is the finest there is, and twice it would be larger, unless it is the
        // coarsest there is. (A directional point outside the finer levels' windows takes a
        // coarser level: only the second half holds there.)
        const double texel = shadow_texel_size(frame, t);
        const ShadowMapView& m = frame.maps[t.map];
        const bool finest = t.mip == 0 && (!m.ortho || m.index == 0);
        const bool coarsest = (pages_per_side >> t.mip) == 1 && (!m.ortho || m.index + 1 == kDirectionalLevels);
        out.wrong_mip += (!m.ortho && !(texel <= f || finest)) || !(2 * texel > f || coarsest);
        const size_t e = shadow_page_entry(frame, t);
        out.unmarked += !frame.needed[e] || frame.page_table[e] == kNoShadowSlot;
        auto& full = brute[{t.map, t.mip}];
        if (full.empty()) full = draw_full_shadow_map(scene.meshes, scene.instances, frame, t.map, t.mip, pool);
        const uint32_t r_m = (pages_per_side * kShadowPageTexels) >> t.mip;
        out.mismatched += shadow_stored_depth(frame, t) != full[size_t(t.y) * r_m + t.x];
        ++out.checked;
      }
    }
  return out;
}

uint64_t check_pages_against_brute_force(const RenderScene& scene, const Camera& camera, uint32_t pages_per_side) {
  PageCheck c = check_pages(scene, camera, pages_per_side);
  EXPECT_EQ(c.unmarked, 0u);
  EXPECT_EQ(c.wrong_mip, 0u);
  EXPECT_EQ(c.dropped, 0u);
  EXPECT_EQ(c.drawn_not_marked, 0u);
  EXPECT_EQ(c.mismatched, 0u) << "of " << c.checked;
  return c.checked;
}

TEST(VirtualShadow, PagesEqualBruteForceMapOfTheSameCutAtEverySampledTexel) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  scene.lights = {directional({-0.4, -0.8, -0.45}), spot({2, 6, 4}, {-0.3, -1, -0.6}, 80), point({1.5, 3.0, 1.5})};
  const Camera cameras[] = {test::look_camera({0, 3, 8}, {0, 1, -2}), test::look_camera({6, 1.5, 2}, {0, 1, -4}),
                            test::look_camera({0, 9, 0.5}, {0, 0, -2})};
  for (const Camera& c : cameras) EXPECT_GT(check_pages_against_brute_force(scene, c, 8), 1000u);
}

// Frames of one history: returns each frame's shadow statistics.
std::vector<ShadowFrameStats> render_frames(RenderScene& scene, const std::vector<Camera>& cameras,
                                            const std::function<void(size_t, RenderScene&)>& change = {}) {
  ThreadPool pool(2);
  RenderSettings settings;
  FrameHistory history;
  std::vector<ShadowFrameStats> out;
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (change) change(i, scene);
    Frame frame;
    render_frame(FrameInputs{scene, cameras[i], settings, pool, &history, i + 1 < cameras.size()}, &frame);
    EXPECT_TRUE(frame.stats.has_shadow);
    out.push_back(frame.stats.shadow);
  }
  return out;
}

TEST(VirtualShadow, StaticSceneSecondFrameDrawsNoPage) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  scene.lights = {directional({-0.4, -0.8, -0.45}), point({1.5, 3.0, 1.5})};
  const Camera c = test::look_camera({0, 3, 8}, {0, 1, -2});
  auto stats = render_frames(scene, {c, c, c});
  EXPECT_GT(stats[0].pages_drawn, 0u);
  EXPECT_EQ(stats[0].pages_drawn, stats[0].pages_marked);
  for (size_t i = 1; i < stats.size(); ++i) {
    EXPECT_EQ(stats[i].pages_drawn, 0u) << i;
    EXPECT_EQ(stats[i].pages_cached, stats[i].pages_marked) << i;
  }
}

TEST(VirtualShadow, MovingLightRedrawsItsPagesAndMovingCasterTheOverlappedOnes) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  scene.lights = {directional({-0.4, -0.8, -0.45}), point({1.5, 3.0, 1.5})};
  const Camera c = test::look_camera({0, 3, 8}, {0, 1, -2});
  auto light_moves = render_frames(scene, {c, c}, [](size_t i, RenderScene& s) {
    if (i == 1) s.lights[1].position.x += 0.25;
  });
  // The point light's pages are all redrawn, the directional light's all reused.
  EXPECT_GT(light_moves[1].pages_drawn, 0u);
  EXPECT_GT(light_moves[1].pages_cached, 0u);
  EXPECT_EQ(light_moves[1].pages_drawn + light_moves[1].pages_cached, light_moves[1].pages_marked);

  RenderScene scene2 = test::make_row_scene(1.0, 0.0, 3);
  scene2.lights = {directional({-0.4, -0.8, -0.45})};
  auto caster_moves = render_frames(scene2, {c, c}, [](size_t i, RenderScene& s) {
    if (i == 1) s.instances[3].object_to_world.at(0, 3) += 0.1;  // the farthest sphere
  });
  EXPECT_GT(caster_moves[1].pages_drawn, 0u);
  EXPECT_LT(caster_moves[1].pages_drawn, caster_moves[1].pages_marked);
}

TEST(VirtualShadow, ImageIsIdenticalForAnyThreadCount) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  scene.lights = {directional({-0.4, -0.8, -0.45}), spot({2, 6, 4}, {-0.3, -1, -0.6}, 80), point({1.5, 3.0, 1.5})};
  const Camera c = test::look_camera({0, 3, 8}, {0, 1, -2});
  std::vector<uint8_t> first;
  for (unsigned threads : {1u, 3u}) {
    ThreadPool pool(threads);
    RenderSettings settings;
    Frame frame;
    render_frame(FrameInputs{scene, c, settings, pool, nullptr, false}, &frame);
    if (first.empty()) first = frame.image.rgb;
    else EXPECT_EQ(frame.image.rgb, first);
  }
}

// Hard cases: a light parallel to the ground, a point light inside a sphere, a spot light at a
// caster's surface: every step finite, nothing dropped, and the lit image differs from ambient.
TEST(VirtualShadow, HardCasesStayFinite) {
  const Camera c = test::look_camera({0, 3, 8}, {0, 1, -2});
  const std::vector<std::vector<Light>> cases = {
      {directional({1, 0, 0})},
      {directional({0, -1, 0})},
      {point({0, 1.2, 0})},                          // the centre of the first sphere
      {spot({0, 2.2, 0}, {0, -1, 0}, 170)},          // at the sphere's top, a near-hemisphere cone
  };
  for (const auto& lights : cases) {
    RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
    scene.lights = lights;
    ThreadPool pool(2);
    RenderSettings settings;
    Frame frame;
    render_frame(FrameInputs{scene, c, settings, pool, nullptr, false}, &frame);
    ASSERT_TRUE(frame.stats.has_shadow);
    EXPECT_EQ(frame.stats.shadow.pages_dropped, 0u);
    EXPECT_EQ(frame.image.rgb.size(), size_t(c.width) * c.height * 3);
    for (const ShadowMapView& m : frame.shadow.maps)
      for (double v : m.light_to_clip.m) EXPECT_TRUE(std::isfinite(v));
  }
}

TEST(VirtualShadow, NoShadowingLightSkipsTheShadowSteps) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 1);
  ThreadPool pool(2);
  RenderSettings settings;
  for (bool with_light : {false, true}) {
    scene.lights.clear();
    if (with_light) {
      scene.lights = {directional({0, -1, 0})};
      scene.lights[0].shadows = false;
    }
    Frame frame;
    render_frame(FrameInputs{scene, test::look_camera({0, 3, 8}, {0, 1, -2}), settings, pool, nullptr, false}, &frame);
    EXPECT_FALSE(frame.stats.has_shadow);
    int skipped = 0;
    for (const auto& [name, reason] : frame.stats.skipped)
      if (name == "shadow_mark" || name == "shadow_draw") {
        EXPECT_EQ(reason, "no shadowing light");
        ++skipped;
      }
    EXPECT_EQ(skipped, 2);
  }
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

// The clipmap's edges: a camera at the scene's rim looking outwards and one far above it; every
// sampled texel still equals the brute-force map (pages at the level windows' borders included).
TEST(VirtualShadow, ClipmapEdgePagesEqualBruteForce) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  scene.lights = {directional({-0.3, -0.5, 0.8})};
  const Camera cameras[] = {test::look_camera({14, 1.5, 14}, {0, 0, -6}), test::look_camera({0, 40, 1}, {0, 0, 0})};
  for (const Camera& c : cameras) EXPECT_GT(check_pages_against_brute_force(scene, c, 8), 100u);
}

// A moving camera: the directional levels' windows move; pages keep their world keys, so the
// second frame reuses the pages it still needs and draws only the new ones.
TEST(VirtualShadow, MovingCameraReusesWorldPages) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  scene.lights = {directional({-0.4, -0.8, -0.45})};
  auto stats = render_frames(scene, {test::look_camera({0, 3, 8}, {0, 1, -2}), test::look_camera({0.5, 3, 7.5}, {0.5, 1, -2.5})});
  EXPECT_GT(stats[1].pages_cached, 0u);
  EXPECT_EQ(stats[1].pages_cached + stats[1].pages_drawn, stats[1].pages_marked);
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

TEST(VirtualShadow, PlanSkipsShadowStepsWithTheirReasons) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 1);
  scene.lights = {directional({0, -1, 0})};
  RenderSettings settings;
  FrameContext context;
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kShadowMark).when, StepCondition::kRun);
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kShadowDraw).when, StepCondition::kRun);
  settings.view = ShadeView::kTriangle;
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kShadowMark).skip_reason, "shadows not shown by this view");
  settings.view = ShadeView::kLit;
  settings.shade = false;
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kShadowDraw).skip_reason, "shading not requested");
  // An unshaded frame whose pages outlive it (a history's cache, a streamer's requests) draws them.
  context.keep_history = true;
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kShadowDraw).when, StepCondition::kRun);
  context.keep_history = false;
  settings.shade = true;
  context.streamed = true;  // shadows run with streaming too (spec/shadow.md §9)
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kShadowMark).when, StepCondition::kRun);
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kShadowDraw).when, StepCondition::kRun);
}

// spec/shadow.md §2: one white directional light along the fixed light's direction, without
// shadows, shades as the scene without lights (to the rounding of the two formulas: at most one
// 8-bit step); with shadows every pixel is as bright or darker, and some are darker.
TEST(VirtualShadow, LightSumMatchesTheFixedLightAndShadowsOnlyDarken) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  const Camera c = test::look_camera({0, 3, 8}, {0, 1, -2});
  ThreadPool pool(2);
  RenderSettings settings;
  auto image = [&]() {
    Frame frame;
    render_frame(FrameInputs{scene, c, settings, pool, nullptr, false}, &frame);
    return frame.image.rgb;
  };
  const std::vector<uint8_t> fixed = image();
  scene.lights = {directional({-0.4, -0.8, -0.45})};
  scene.lights[0].shadows = false;
  const std::vector<uint8_t> unshadowed = image();
  scene.lights[0].shadows = true;
  const std::vector<uint8_t> shadowed = image();
  ASSERT_EQ(fixed.size(), unshadowed.size());
  int max_step = 0;
  uint64_t darker = 0, brighter = 0;
  for (size_t i = 0; i < fixed.size(); ++i) {
    max_step = std::max(max_step, std::abs(int(fixed[i]) - int(unshadowed[i])));
    darker += shadowed[i] < unshadowed[i];
    brighter += shadowed[i] > unshadowed[i];
  }
  EXPECT_LE(max_step, 1);
  EXPECT_GT(darker, 100u);
  EXPECT_EQ(brighter, 0u);
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

const RenderScene& property_scene() {
  static const RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  return scene;
}

// A random light of each type (directions including axis-aligned and grazing ones, positions
// inside and around the casters) and camera over property_scene(), for the property tests.
struct RandomLightCase {
  RenderScene scene;
  Camera camera;
};

RandomLightCase random_light_case() {
  RandomLightCase c{property_scene(), {}};
  const int type = *rc::gen::inRange(0, 3);
  auto coord = [](int lo, int hi) { return *rc::gen::inRange(lo, hi) * 0.5; };
  Vec3d d{coord(-4, 5), coord(-4, 1), coord(-4, 5)};
  if (d.x == 0 && d.y == 0 && d.z == 0) d.y = -1;
  Vec3d p{coord(-8, 9), coord(1, 12), coord(-12, 5)};
  if (type == 0) c.scene.lights = {directional(d)};
  else if (type == 1) c.scene.lights = {spot(p, d, *rc::gen::element(20.0, 60.0, 120.0, 170.0))};
  else c.scene.lights = {point(p)};
  c.camera = test::look_camera({coord(-16, 17), coord(1, 16), coord(-10, 20)}, {coord(-4, 5), 1.0, coord(-10, 2)},
                               *rc::gen::element(64u, 160u), *rc::gen::element(48u, 120u));
  return c;
}

// Random lights (each type, directions including axis-aligned and grazing ones, positions inside
// and around the casters), cameras and τ on a shrunk page table: every sampled texel is marked,
// has a slot, is of the right mip and equals the brute-force map of the same cut.
RC_GTEST_PROP(VirtualShadow, RandomLightsPagesEqualBruteForce, ()) {
  const auto [scene, camera] = random_light_case();
  const PageCheck c = check_pages(scene, camera, *rc::gen::element(4u, 8u), *rc::gen::element(0.5f, 1.0f, 4.0f));
  RC_CLASSIFY(c.checked == 0, "no texel sampled");
  RC_ASSERT(c.ok());
}

}  // namespace
}  // namespace vgeo

#include "support/paths.h"
#include "vgeo/render/run.h"
#include "vgeo/render/scene_file.h"

namespace vgeo {
namespace {

// The example light scenes load through the scene file and render with their shadow passes.
TEST(VirtualShadow, ExampleLightScenesRenderWithShadowPasses) {
  for (const char* name : {"directional.json", "spot.json", "point.json"}) {
    SceneFile f = load_scene_file((test::source_dir() / "tests" / "shadow" / "scenes" / name).string(), {});
    ASSERT_EQ(f.scene.lights.size(), 1u) << name;
    RenderRequest r;
    r.threads = 2;
    RenderReport report = render_scene(f, r);
    ASSERT_FALSE(report.frames.empty()) << name;
    const FrameStats& last = report.frames.back();
    EXPECT_NE(last.find("shadow_mark"), nullptr) << name;
    EXPECT_NE(last.find("shadow_draw"), nullptr) << name;
    EXPECT_TRUE(last.has_shadow) << name;
    EXPECT_GT(last.shadow.pages_drawn, 0u) << name;
    EXPECT_EQ(last.shadow.pages_dropped, 0u) << name;
  }
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

// ---- spec/shadow.md §6: the screen-space trace over the LOD-mismatch zone ----

// A flat 20 x 20 ground (normal +Y) at height `height`: the only geometry of the scene.
RenderScene flat_ground_scene(double height) {
  RenderScene s;
  s.materials = {Material{"a", {0.8f, 0.8f, 0.8f, 1}}};
  BuildOptions bo;
  bo.threads = 1;
  Mesh grid = test::make_grid(32);  // XY plane, CCW from +Z
  grid.materials.assign(grid.triangle_count(), 0);
  s.meshes.push_back(build_dag(grid, bo));
  Mat4d m;  // (x, y, z) → (20x − 10, height, 10 − 20y): +Z normal → +Y
  for (double& v : m.m) v = 0;
  m.at(0, 0) = 20;
  m.at(0, 3) = -10;
  m.at(1, 2) = 20;
  m.at(1, 3) = height;
  m.at(2, 1) = -20;
  m.at(2, 3) = 10;
  m.at(3, 3) = 1;
  s.instances.push_back({0, m});
  analyze_render_scene(&s);
  return s;
}

ShadowReceiver receiver_at(const Frame& primary, uint32_t x, uint32_t y, const Vec3d& normal, const Vec3d& to_light) {
  ShadowReceiver r;
  r.x = x;
  r.y = y;
  const uint64_t key = primary.vis.keys[size_t(y) * primary.vis.width + x];
  r.p = shadow_sample_point(primary.view, rigid_inverse(primary.view.world_to_view), x, y, vis_key_depth(key), &r.footprint);
  r.normal = normal;
  r.to_light = to_light;
  r.cos_nl = dot(normal, to_light);
  return r;
}

// The light's coarser LOD poking through the finer primary surface: the shadow map is drawn from
// the ground raised by δ = 0.9 × the smallest τ·f + τ_s·T over the pixels (a shadow cut within
// its error bound of the primary one), the primary view sees the ground itself, the light grazes
// (c = 0.15, inside the zone's secant range c ≥ 1/8). The map alone reports an occluder beyond the sampling bias at many pixels, and the
// bias of the previous version (b_t + τ·f + τ_s·T, no secant) shadows some of them: acne, as
// nothing but the receiver is in the scene. Every such pixel is within the zone, and the trace
// finds no caster there: no pixel is shadowed.
TEST(ShadowTrace, RemovesAcneWhereTheLightsCoarserCutPokesThroughThePrimarySurface) {
  ThreadPool pool(2);
  const Camera camera = test::look_camera({0, 4, 8}, {0, 0, 0});
  const RenderScene ground = flat_ground_scene(0.0);
  const Frame primary = primary_frame(ground, camera, pool);
  const Vec3d to_light = [] {
    Vec3d l{0.9887, 0.15, 0};
    double n = std::sqrt(dot(l, l));
    return Vec3d{l.x / n, l.y / n, l.z / n};
  }();
  const std::vector<Light> lights = {directional({-to_light.x, -to_light.y, -to_light.z})};
  const Vec3d up{0, 1, 0};
  ShadowOptions options;
  options.pages_per_side = 8;
  options.pool_pages = 1u << 16;
  // δ from the ground's own frame (raising a flat ground leaves r, the texel sizes and mips as
  // they are).
  ShadowFrame probe = make_shadow_frame(lights, shadow_scene_bounds(ground.meshes, ground.instances), camera.position,
                                        options);
  double min_bound = std::numeric_limits<double>::infinity();
  uint64_t covered = 0;
  for (uint32_t y = 0; y < primary.vis.height; ++y)
    for (uint32_t x = 0; x < primary.vis.width; ++x) {
      if (!primary.vis.keys[size_t(y) * primary.vis.width + x]) continue;
      ShadowReceiver r = receiver_at(primary, x, y, up, to_light);
      ShadowTexel t;
      ASSERT_TRUE(select_shadow_texel(probe, 0, r.p, r.footprint, &t));
      min_bound = std::min(min_bound, options.threshold_px * r.footprint +
                                          double(kShadowLodBias) * options.threshold_px * shadow_texel_size(probe, t));
      ++covered;
    }
  ASSERT_GT(covered, 5000u);
  const double delta = 0.9 * min_bound;
  RenderScene raised = flat_ground_scene(delta);
  raised.lights = lights;
  ShadowFrame frame = make_shadow_frame(lights, shadow_scene_bounds(raised.meshes, raised.instances), camera.position,
                                        options);
  mark_shadow_pages(primary.vis, primary.view, lights, pool, &frame);
  draw_shadow_pages(raised.meshes, raised.instances, lights, pool, &frame, nullptr);
  const ShadowScreen screen = make_shadow_screen(primary.vis, primary.view);
  uint64_t map_occluded = 0, old_bias_shadowed = 0, shadowed = 0, far = 0;
  for (uint32_t y = 0; y < primary.vis.height; ++y)
    for (uint32_t x = 0; x < primary.vis.width; ++x) {
      if (!primary.vis.keys[size_t(y) * primary.vis.width + x]) continue;
      ShadowReceiver r = receiver_at(primary, x, y, up, to_light);
      ShadowTestDetail d = shadow_test(frame, 0, r, screen);
      ASSERT_NE(d.decision, ShadowDecision::kNoTexel);
      map_occluded += d.stored > d.d_lit;
      far += d.decision == ShadowDecision::kFarCaster;
      shadowed += shadow_term(frame, 0, r, screen) == 0.0f;
      const double texel = shadow_texel_size(frame, d.texel);
      const double s = std::sqrt(1 - r.cos_nl * r.cos_nl) / r.cos_nl;
      const double old_bias = texel * (1 + s) + r.footprint + double(kShadowLodBias) * texel;
      old_bias_shadowed += d.stored > float(1 - (d.texel.dist - old_bias) / frame.maps[d.texel.map].depth_range);
    }
  EXPECT_GT(map_occluded, 1000u);
  EXPECT_GT(old_bias_shadowed, 100u);
  EXPECT_EQ(far, 0u);
  EXPECT_EQ(shadowed, 0u) << "of " << map_occluded << " pixels the map alone shadows";
}

// The map and the decision at every covered pixel of random lights and cameras (normals between
// the light and the eye, so c and the view slope vary): a pixel whose brute-force map texel is
// nearer the light than the zone's far end D (a far caster, spec arithmetic recomputed here) is
// shadowed without a trace; a pixel is lit only when the map shows nothing beyond the sampling
// bias or the trace found nothing in the zone; the trace reads at most kShadowTraceMaxSteps texels.
RC_GTEST_PROP(ShadowTrace, NeverLightsAPixelTheBruteForceMapSaysAFarCasterShadows, ()) {
  const auto [scene, camera] = random_light_case();
  ThreadPool pool(2);
  const Frame primary = primary_frame(scene, camera, pool);
  ShadowOptions options;
  options.pages_per_side = *rc::gen::element(4u, 8u);
  options.pool_pages = 1u << 16;
  ShadowFrame frame = make_shadow_frame(scene.lights, shadow_scene_bounds(scene.meshes, scene.instances),
                                        camera.position, options);
  mark_shadow_pages(primary.vis, primary.view, scene.lights, pool, &frame);
  draw_shadow_pages(scene.meshes, scene.instances, scene.lights, pool, &frame, nullptr);
  const ShadowScreen screen = make_shadow_screen(primary.vis, primary.view);
  std::map<std::pair<uint32_t, uint32_t>, std::vector<float>> brute;
  const Light& light = scene.lights[0];
  uint64_t far = 0, traced = 0, hits = 0;
  for (uint32_t y = 0; y < primary.vis.height; ++y)
    for (uint32_t x = 0; x < primary.vis.width; ++x) {
      if (!primary.vis.keys[size_t(y) * primary.vis.width + x]) continue;
      ShadowReceiver r = receiver_at(primary, x, y, {0, 1, 0}, {0, 0, 1});
      Vec3d l = light.type == LightType::kDirectional ? Vec3d{-light.direction.x, -light.direction.y, -light.direction.z}
                                                      : sub(light.position, r.p);
      const double ll = std::sqrt(dot(l, l));
      if (!(ll > 0)) continue;
      l = {l.x / ll, l.y / ll, l.z / ll};
      Vec3d v = sub(screen.camera, r.p);
      const double vl = std::sqrt(dot(v, v));
      Vec3d n{l.x + v.x / vl, l.y + v.y / vl, l.z + v.z / vl};
      const double nl = std::sqrt(dot(n, n));
      if (!(nl > 1e-9)) continue;
      r.normal = {n.x / nl, n.y / nl, n.z / nl};
      r.to_light = l;
      r.cos_nl = dot(r.normal, l);
      if (!(r.cos_nl > 0)) continue;
      const ShadowTestDetail det = shadow_test(frame, 0, r, screen);
      if (det.decision == ShadowDecision::kNoTexel) continue;
      auto& full = brute[{det.texel.map, det.texel.mip}];
      if (full.empty()) full = draw_full_shadow_map(scene.meshes, scene.instances, frame, det.texel.map, det.texel.mip, pool);
      const uint32_t r_m = (options.pages_per_side * kShadowPageTexels) >> det.texel.mip;
      const float stored = full[size_t(det.texel.y) * r_m + det.texel.x];
      RC_ASSERT(stored == det.stored);
      // spec/shadow.md §6 recomputed: D = T(1 + s) + (τf + τ_s T)(1 + s).
      const ShadowMapView& m = frame.maps[det.texel.map];
      const double texel = shadow_texel_size(frame, det.texel);
      const double s = std::min(std::sqrt(std::max(0.0, 1 - r.cos_nl * r.cos_nl)) / r.cos_nl, kMaxShadowSlope);
      const double zone = texel * (1 + s) + (r.footprint + double(kShadowLodBias) * texel) * std::min(1 + s, kMaxMismatchSecant);
      const double dz = det.texel.dist - zone;
      const float d_far = m.ortho ? float(1 - dz / m.depth_range) : float(m.z_near / std::max(dz, m.z_near));
      const float term = shadow_term(frame, 0, r, screen);
      if (stored > d_far) {
        RC_ASSERT(term == 0.0f);
        RC_ASSERT(det.decision == ShadowDecision::kFarCaster);
        ++far;
      }
      if (term == 1.0f) RC_ASSERT(!(stored > det.d_lit) || det.decision == ShadowDecision::kTraceMiss);
      RC_ASSERT(det.trace_steps <= kShadowTraceMaxSteps);
      traced += det.decision == ShadowDecision::kTraceHit || det.decision == ShadowDecision::kTraceMiss;
      hits += det.decision == ShadowDecision::kTraceHit;
    }
  RC_CLASSIFY(far > 0, "far casters");
  RC_CLASSIFY(traced > 0, "traced");
  RC_CLASSIFY(hits > 0, "trace hits");
}

// Contact shadows: a thin caster (a 2 x 2 sheet, a leaf) 0.1 above the flat ground, lit at 60°
// from the vertical (c = 0.5): the ground strip it shadows has the sheet 0.2 away along the
// light, inside the zone D ≈ 0.31 here. The trace finds the sheet at some of those pixels, and
// every pixel it shadows is truly in the sheet's shadow (the light ray from its sample point
// crosses the sheet; exact here). Where the ray passes under the sheet by less than ε (near the
// sheet's edge) the trace misses and the pixel is lit: spec/shadow.md §6's stated limitation.
TEST(ShadowTrace, FindsAThinCasterNearItsReceiverAndOnlyIt) {
  RenderScene scene = flat_ground_scene(0.0);
  BuildOptions bo;
  bo.threads = 1;
  Mesh sheet = test::make_grid(8);
  sheet.materials.assign(sheet.triangle_count(), 0);
  scene.meshes.push_back(build_dag(sheet, bo));
  const double sheet_height = 0.1;
  Mat4d m = scene.instances[0].object_to_world;  // as the ground: (x, y) → (2x − 1, 0.1, 1 − 2y)
  m.at(0, 0) = 2;
  m.at(0, 3) = -1;
  m.at(1, 3) = sheet_height;
  m.at(2, 1) = -2;
  m.at(2, 3) = 1;
  scene.instances.push_back({1, m});
  analyze_render_scene(&scene);
  scene.lights = {directional({0.8660254037844386, -0.5, 0})};
  const Camera camera = test::look_camera({0, 2, 3}, {0, 0, 0});
  ThreadPool pool(2);
  const Frame primary = primary_frame(scene, camera, pool);
  ShadowFrame frame = make_shadow_frame(scene.lights, shadow_scene_bounds(scene.meshes, scene.instances),
                                        camera.position, ShadowOptions{});
  mark_shadow_pages(primary.vis, primary.view, scene.lights, pool, &frame);
  draw_shadow_pages(scene.meshes, scene.instances, scene.lights, pool, &frame, nullptr);
  const ShadowScreen screen = make_shadow_screen(primary.vis, primary.view);
  const Vec3d l{-scene.lights[0].direction.x, -scene.lights[0].direction.y, -scene.lights[0].direction.z};
  std::map<ShadowDecision, uint64_t> count;
  uint64_t false_hits = 0;
  for (uint32_t y = 0; y < primary.vis.height; ++y)
    for (uint32_t x = 0; x < primary.vis.width; ++x) {
      const uint64_t key = primary.vis.keys[size_t(y) * primary.vis.width + x];
      if (!key || primary.visible[vis_key_cluster(key)].instance != 0) continue;  // ground pixels
      ShadowReceiver r = receiver_at(primary, x, y, {0, 1, 0}, l);
      const ShadowTestDetail d = shadow_test(frame, 0, r, screen);
      ++count[d.decision];
      if (d.decision != ShadowDecision::kTraceHit) continue;
      const double t = (sheet_height - r.p.y) / l.y;  // where the light ray reaches the sheet's plane
      const double cx = r.p.x + t * l.x, cz = r.p.z + t * l.z;
      false_hits += !(std::abs(cx) <= 1 && std::abs(cz) <= 1);
    }
  EXPECT_GT(count[ShadowDecision::kFarCaster], 100u);
  EXPECT_GT(count[ShadowDecision::kLit], 1000u);
  EXPECT_GT(count[ShadowDecision::kTraceHit], 10u);
  EXPECT_EQ(false_hits, 0u);
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

// spec/shadow.md §1: in a sequence (a history), every frame draws its shadow pages, shaded or
// not, so the last frame's image is the same whether the frames before it were shaded (saved)
// or not: a directional light (its clipmap windows move with the camera, so which frame drew a
// cached page matters) and a moving camera.
TEST(VirtualShadow, LastImageDoesNotDependOnWhichEarlierFramesWereShaded) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  scene.lights = {directional({-0.4, -0.8, -0.45})};
  const std::vector<Camera> cameras = {test::look_camera({0, 3, 8}, {0, 1, -2}), test::look_camera({1.5, 3, 6}, {0, 1, -3}),
                                       test::look_camera({3, 2.5, 4}, {0, 1, -4})};
  ThreadPool pool(2);
  std::vector<uint8_t> images[2];
  for (int shade_all = 0; shade_all < 2; ++shade_all) {
    FrameHistory history;
    for (size_t i = 0; i < cameras.size(); ++i) {
      RenderSettings settings;
      const bool last = i + 1 == cameras.size();
      settings.shade = shade_all || last;
      Frame frame;
      render_frame(FrameInputs{scene, cameras[i], settings, pool, &history, !last}, &frame);
      EXPECT_TRUE(frame.stats.has_shadow) << i;
      if (last) images[shade_all] = frame.image.rgb;
    }
  }
  EXPECT_FALSE(images[0].empty());
  EXPECT_EQ(images[0], images[1]);
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

// Hard cases against the brute-force map: every sampled texel marked, of the right mip
// and equal to the full-resolution map of the same cut. A directional light parallel to the
// ground (grazing: the ground's own bumps are its casters), a caster crossing the light's near
// plane (a sheet tilted through a point light's position, and a spot light lying in a sheet's
// plane: the near-plane clip and the whole-mip texel rectangle), a point light inside a closed
// mesh, and the clipmap's edges (ClipmapEdgePagesEqualBruteForce).
TEST(VirtualShadow, HardCasesPagesEqualBruteForce) {
  const Camera camera = test::look_camera({0, 3, 8}, {0, 1, -2});
  {
    RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
    for (const Light& l : {directional({1, 0, 0}), directional({0, -1e-3, -1}), point({0, 1.2, 0})}) {
      scene.lights = {l};
      EXPECT_GT(check_pages_against_brute_force(scene, camera, 8), 1000u);
    }
  }
  RenderScene scene = flat_ground_scene(0.0);
  BuildOptions bo;
  bo.threads = 1;
  Mesh sheet = test::make_grid(8);
  sheet.materials.assign(sheet.triangle_count(), 0);
  scene.meshes.push_back(build_dag(sheet, bo));
  Mat4d m = scene.instances[0].object_to_world;  // a 2 x 2 sheet through (0, 1, 0), tilted 45° about x
  m.at(0, 0) = 2;
  m.at(0, 3) = -1;
  m.at(1, 2) = 0;
  m.at(1, 1) = -std::sqrt(2.0);
  m.at(1, 3) = 1 + std::sqrt(0.5);
  m.at(2, 1) = -std::sqrt(2.0);
  m.at(2, 2) = 0;
  m.at(2, 3) = std::sqrt(0.5);
  m.at(2, 0) = 0;
  scene.instances.push_back({1, m});
  analyze_render_scene(&scene);
  for (const Light& l : {point({0, 1, 0}), spot({0.2, 1, -0.2}, {0, -1, 1}, 120), point({0.3, 1.0 + 1e-9, 0.1})}) {
    scene.lights = {l};
    EXPECT_GT(check_pages_against_brute_force(scene, camera, 8), 1000u);
  }
}

// A point light inside a closed, star-shaped mesh (the first sphere of the row scene, light at its
// centre): no light leaves it. Every pixel of every other instance shades as with the light at
// intensity 0 (its surfaces face away, c ≤ 0, or the enclosing mesh is a far caster).
TEST(VirtualShadow, PointLightInsideAClosedMeshLightsNothingOutside) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  const Camera camera = test::look_camera({0, 3, 8}, {0, 1, -2});
  ThreadPool pool(2);
  RenderSettings settings;
  scene.lights = {point({0, 1.2, 0})};
  Frame lit;
  render_frame(FrameInputs{scene, camera, settings, pool, nullptr, false}, &lit);
  ASSERT_TRUE(lit.stats.has_shadow);
  scene.lights[0].intensity = 0;
  Frame dark;
  render_frame(FrameInputs{scene, camera, settings, pool, nullptr, false}, &dark);
  ASSERT_EQ(lit.vis.keys, dark.vis.keys);
  uint64_t outside = 0, differ = 0;
  for (size_t p = 0; p < lit.vis.keys.size(); ++p) {
    const uint64_t key = lit.vis.keys[p];
    if (!key || lit.visible[vis_key_cluster(key)].instance == 1) continue;  // instance 1 encloses the light
    ++outside;
    for (int c = 0; c < 3; ++c) differ += lit.image.rgb[3 * p + c] != dark.image.rgb[3 * p + c];
  }
  EXPECT_GT(outside, 5000u);
  EXPECT_EQ(differ, 0u);
}

}  // namespace
}  // namespace vgeo
