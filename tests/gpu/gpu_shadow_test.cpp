// Virtual shadow pages on Vulkan against the CPU reference (spec/shadow.md §5): from the same
// marked pages, draw_shadow_pages_vulkan allocates the same slots, reuses the same cached pages
// and writes every physical pool texel bit-identical to draw_shadow_pages, on the three example
// light scenes and over two frames with a moving caster and a moving light.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "gpu/gpu_testing.h"
#include "support/paths.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/render/compare.h"
#include "vgeo/render/frame.h"
#include "vgeo/render/scene_file.h"
#include "vgeo/shadow/shadow_hw_rule.h"

namespace vgeo {
namespace {

SceneFile load_light_scene(const char* name) {
  return load_scene_file((test::source_dir() / "tests" / "shadow" / "scenes" / name).string(), {});
}

// The frame's maps and needed pages from the CPU's visibility buffer (marking is the CPU's code
// on both backends).
ShadowFrame marked_frame(const RenderScene& scene, const Camera& camera, ThreadPool& pool) {
  RenderSettings settings;
  settings.shade = false;
  Frame primary;
  render_frame(FrameInputs{scene, camera, settings, pool, nullptr, false}, &primary);
  ShadowFrame frame = make_shadow_frame(scene.lights, shadow_scene_bounds(scene.meshes, scene.instances),
                                        camera.position, ShadowOptions{});
  mark_shadow_pages(primary.vis, primary.view, scene.lights, pool, &frame);
  return frame;
}

// Bitwise comparison of two pools (float bits, so 0 and −0 or NaNs never pass by accident).
size_t differing_texels(const std::vector<float>& a, const std::vector<float>& b, size_t* first) {
  size_t n = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    uint32_t x, y;
    std::memcpy(&x, &a[i], 4);
    std::memcpy(&y, &b[i], 4);
    if (x != y && n++ == 0) *first = i;
  }
  return n;
}

// One frame drawn by both backends, each with its own cache; everything the draw decides and
// writes must agree.
// Returns the CPU's counters.
ShadowFrameStats expect_same_draw(GpuRenderer& renderer, const RenderScene& scene, const Camera& camera,
                                  ThreadPool& pool, ShadowCache* cpu_cache, ShadowCache* vk_cache,
                                  const std::string& what) {
  ShadowFrame cpu = marked_frame(scene, camera, pool);
  ShadowFrame vk = cpu;
  draw_shadow_pages(scene.meshes, scene.instances, scene.lights, pool, &cpu, cpu_cache);
  draw_shadow_pages_vulkan(renderer, scene, pool, &vk, vk_cache);
  EXPECT_EQ(cpu.page_table, vk.page_table) << what;
  EXPECT_EQ(cpu.pages_marked, vk.pages_marked) << what;
  EXPECT_EQ(cpu.pages_cached, vk.pages_cached) << what;
  EXPECT_EQ(cpu.pages_drawn, vk.pages_drawn) << what;
  EXPECT_EQ(cpu.clusters_drawn, vk.clusters_drawn) << what;
  const std::vector<float>& a = cpu.pool_texels ? *cpu.pool_texels : cpu.own_texels;
  const std::vector<float>& b = vk.pool_texels ? *vk.pool_texels : vk.own_texels;
  EXPECT_EQ(a.size(), b.size()) << what;
  size_t first = 0;
  const size_t differing = differing_texels(a, b, &first);
  EXPECT_EQ(differing, 0u) << what << ": first at texel " << first << " (slot " << first / (128 * 128) << ") cpu "
                           << a[first] << " vulkan " << b[first];
  uint64_t drawn = 0;
  for (float t : a) drawn += t != 0.0f;
  EXPECT_GT(drawn, 0u) << what << ": no texel drawn, the comparison would prove nothing";
  return shadow_frame_stats(cpu);
}

TEST(GpuShadow, PoolTexelsBitIdenticalToCpuOnTheExampleScenes) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  ThreadPool pool(2);
  for (const char* name : {"directional.json", "spot.json", "point.json"}) {
    SceneFile sf = load_light_scene(name);
    GpuRendererPtr renderer = create_gpu_renderer(*gpu, sf.scene, memory_form_pages(sf));
    ShadowCache cpu_cache, vk_cache;
    expect_same_draw(*renderer, sf.scene, sf.cameras[0], pool, &cpu_cache, &vk_cache, name);
    // No cache kept: the frame's own pool.
    expect_same_draw(*renderer, sf.scene, sf.cameras[0], pool, nullptr, nullptr, std::string(name) + " uncached");
  }
  testing::expect_no_validation_messages(*gpu);
}

TEST(GpuShadow, MovingCasterAndMovingLightRedrawTheSamePagesAsCpu) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  ThreadPool pool(2);
  SceneFile sf = load_light_scene("spot.json");
  RenderScene scene = sf.scene;
  GpuRendererPtr renderer = create_gpu_renderer(*gpu, scene, memory_form_pages(sf));
  ShadowCache cpu_cache, vk_cache;
  Camera camera = sf.cameras[0];
  expect_same_draw(*renderer, scene, camera, pool, &cpu_cache, &vk_cache, "frame 0");
  // A caster moves (the rock at x = −3): only the pages its sphere overlaps are redrawn.
  scene.instances[3].object_to_world.at(0, 3) += 0.2;
  const ShadowFrameStats caster = expect_same_draw(*renderer, scene, camera, pool, &cpu_cache, &vk_cache, "caster moved");
  EXPECT_GT(caster.pages_drawn, 0u);
  EXPECT_GT(caster.pages_cached, 0u);
  // The light and the camera move: every page of the light is redrawn.
  scene.lights[0].position.x += 0.3;
  camera.position.x += 0.5;
  const ShadowFrameStats light =
      expect_same_draw(*renderer, scene, camera, pool, &cpu_cache, &vk_cache, "light and camera moved");
  EXPECT_EQ(light.pages_cached, 0u);
  EXPECT_EQ(light.pages_drawn, light.pages_marked);
  testing::expect_no_validation_messages(*gpu);
}

// The whole lit frame through both executors (spec/shadow.md §6, spec/raster.md §Backends
// agree): shadow_mark and shadow_draw run on Vulkan, the pages equal the CPU's bit for bit and
// the shaded image (with the shadow terms) keeps the rule, over frames where a caster and then
// the light move, each backend with its own history (its own cache).
TEST(GpuShadow, LitFramesKeepTheRuleWithShadowPagesComparedOverMovingFrames) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  ThreadPool pool(2);
  for (const char* name : {"directional.json", "point.json"}) {
    SceneFile sf = load_light_scene(name);
    RenderScene scene = sf.scene;
    GpuRendererPtr renderer = create_gpu_renderer(*gpu, scene, memory_form_pages(sf));
    FrameHistory cpu_history, vk_history;
    for (int f = 0; f < 3; ++f) {
      if (f == 1) scene.instances[3].object_to_world.at(0, 3) += 0.2;  // a caster moves
      if (f == 2) {  // the light moves
        if (scene.lights[0].type == LightType::kPoint) scene.lights[0].position.y += 0.3;
        else scene.lights[0].direction = {-0.4 / std::sqrt(0.96), -0.8 / std::sqrt(0.96), -0.4 / std::sqrt(0.96)};
      }
      Frame cpu, vk;
      render_frame({scene, sf.cameras[0], sf.settings, pool, &cpu_history, true}, &cpu);
      render_frame_vulkan(*renderer, {scene, sf.cameras[0], sf.settings, pool, &vk_history, true}, &vk);
      const std::string what = std::string(name) + " frame " + std::to_string(f);
      ASSERT_TRUE(cpu.stats.has_shadow && vk.stats.has_shadow) << what;
      EXPECT_GT(cpu.stats.shadow.pages_marked, 0u) << what;
      if (f == 1) {
        EXPECT_GT(cpu.stats.shadow.pages_cached, 0u) << what;
        EXPECT_GT(cpu.stats.shadow.pages_drawn, 0u) << what;
      }
      const FrameComparison c = compare_frames(scene, scene.meshes, sf.cameras[0], cpu, vk, false);
      EXPECT_TRUE(c.shadow_compared) << what;
      EXPECT_TRUE(c.shadow_tables_equal) << what;
      EXPECT_EQ(c.shadow_texels_differing, 0u) << what;
      EXPECT_TRUE(c.shaded) << what;
      EXPECT_EQ(c.vis_pixels_differing, 0u) << what;
      EXPECT_LE(c.max_channel_diff, 1) << what;
      EXPECT_TRUE(c.holds()) << what;
    }
  }
  testing::expect_no_validation_messages(*gpu);
}

// The pool's texels of every page `frame` drew, classified by the shadow-page hardware rule
// (spec/shadow.md §8) against `reference` (the CPU's frame, same marks, so the same slots).
HwRasterAgreement classify_drawn_pages(const RenderScene& scene, const ShadowFrame& reference,
                                       const std::vector<float>& hardware_texels) {
  const std::vector<float>& ref = reference.pool_texels ? *reference.pool_texels : reference.own_texels;
  const size_t page_texels = size_t(kShadowPageTexels) * kShadowPageTexels;
  HwRasterAgreement agreement;
  for (size_t d = 0; d < reference.drawn->pages.size(); ++d) {
    const size_t at = reference.drawn->pages[d].slot * page_texels;
    classify_shadow_page_hw(scene.meshes, scene.instances, *reference.drawn, d, ref.data() + at,
                            hardware_texels.data() + at, &agreement);
  }
  return agreement;
}

// The hardware raster path of the shadow pages (spec/shadow.md §8): from the same marked pages,
// the same allocation and counters as the CPU, and every texel of the drawn pages within the
// shadow-page hardware rule; a planted error (one page's texels written one row off, or into
// another page's slot) breaks it.
TEST(GpuShadow, HardwareRasterPagesKeepTheShadowPageRuleOnTheExampleScenes) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  ThreadPool pool(2);
  for (const char* name : {"directional.json", "spot.json", "point.json"}) {
    SceneFile sf = load_light_scene(name);
    GpuRendererPtr renderer = create_gpu_renderer(*gpu, sf.scene, memory_form_pages(sf));
    ShadowFrame cpu = marked_frame(sf.scene, sf.cameras[0], pool);
    ShadowFrame vk = cpu;
    draw_shadow_pages(sf.scene.meshes, sf.scene.instances, sf.scene.lights, pool, &cpu, nullptr);
    draw_shadow_pages_vulkan(*renderer, sf.scene, pool, &vk, nullptr, GpuRasterMode::kHw);
    EXPECT_EQ(cpu.page_table, vk.page_table) << name;
    EXPECT_EQ(shadow_frame_stats(cpu), shadow_frame_stats(vk)) << name;
    ASSERT_TRUE(cpu.drawn && vk.drawn) << name;
    ASSERT_GT(cpu.drawn->pages.size(), 1u) << name;
    const HwRasterAgreement a = classify_drawn_pages(sf.scene, cpu, vk.own_texels);
    uint64_t written = 0;
    for (float t : vk.own_texels) written += t != 0.0f;
    std::printf("%s: %zu pages, %llu texels written; identical %llu, depth only %llu, ambiguous depth %llu, clip %llu, "
                "snap %llu, beyond %llu, violation %llu; max depth error %.3g tol\n",
                name, cpu.drawn->pages.size(), (unsigned long long)written,
                (unsigned long long)a.count(HwPixel::kIdentical), (unsigned long long)a.count(HwPixel::kDepthOnly),
                (unsigned long long)a.count(HwPixel::kAmbiguousDepth),
                (unsigned long long)a.count(HwPixel::kAmbiguousClipCoverage),
                (unsigned long long)a.count(HwPixel::kAmbiguousSnapCoverage),
                (unsigned long long)a.count(HwPixel::kDepthBeyondTolerance), (unsigned long long)a.count(HwPixel::kViolation),
                a.max_depth_error_ratio);
    EXPECT_GT(written, 0u) << name << ": no texel drawn, the comparison would prove nothing";
    EXPECT_EQ(a.failures(), 0u) << name;
    EXPECT_EQ(a.count(HwPixel::kIdentical) + a.count(HwPixel::kDepthOnly) + a.in_mask() + a.failures(),
              cpu.drawn->pages.size() * kShadowPageTexels * kShadowPageTexels)
        << name;

    // Planted errors: the first page with drawn texels written one texel row lower (a wrong
    // page offset), then the same page read from the next drawn page's slot (a wrong slot).
    const size_t page_texels = size_t(kShadowPageTexels) * kShadowPageTexels;
    size_t planted = 0;
    while (planted < cpu.drawn->pages.size()) {
      const size_t at = cpu.drawn->pages[planted].slot * page_texels;
      if (std::any_of(vk.own_texels.begin() + at, vk.own_texels.begin() + at + page_texels, [](float t) { return t != 0; }))
        break;
      ++planted;
    }
    ASSERT_LT(planted, cpu.drawn->pages.size()) << name;
    const size_t at = cpu.drawn->pages[planted].slot * page_texels;
    std::vector<float> shifted = vk.own_texels;
    std::copy(vk.own_texels.begin() + at, vk.own_texels.begin() + at + page_texels - kShadowPageTexels,
              shifted.begin() + at + kShadowPageTexels);
    EXPECT_GT(classify_drawn_pages(sf.scene, cpu, shifted).failures(), 0u) << name << ": a page offset by one row";
    std::vector<float> swapped = vk.own_texels;
    const size_t other = cpu.drawn->pages[(planted + 1) % cpu.drawn->pages.size()].slot * page_texels;
    std::copy(vk.own_texels.begin() + other, vk.own_texels.begin() + other + page_texels, swapped.begin() + at);
    EXPECT_GT(classify_drawn_pages(sf.scene, cpu, swapped).failures(), 0u) << name << ": a page from another slot";
  }
  testing::expect_no_validation_messages(*gpu);
}

// Whole lit frames under --raster hw (the primary view and the shadow pages by the hardware
// raster) and auto (the shadow pages by the compute raster): compare_frames covers the pages
// both sides drew under the shadow-page rule, and the comparison holds.
TEST(GpuShadow, HardwareRasterLitFramesCompareTheShadowPagesUnderTheRule) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  ThreadPool pool(2);
  for (GpuRasterMode mode : {GpuRasterMode::kHw, GpuRasterMode::kAuto})
    for (const char* name : {"directional.json", "spot.json", "point.json"}) {
      SceneFile sf = load_light_scene(name);
      GpuRendererOptions options;
      options.raster = mode;
      GpuRendererPtr renderer =
          create_gpu_renderer(*gpu, sf.scene, memory_form_pages(sf), kDefaultGpuTraversal, options);
      Frame cpu, vk;
      render_frame({sf.scene, sf.cameras[0], sf.settings, pool, nullptr, true}, &cpu);
      render_frame_vulkan(*renderer, {sf.scene, sf.cameras[0], sf.settings, pool, nullptr, true}, &vk);
      const std::string what = std::string(name) + " " + gpu_raster_mode_name(mode);
      const FrameComparison c = compare_frames(sf.scene, sf.scene.meshes, sf.cameras[0], cpu, vk, true);
      EXPECT_TRUE(c.shadow_hw_compared) << what;
      EXPECT_GT(c.shadow_pages_compared, 0u) << what;
      EXPECT_EQ(c.shadow_element_lists_differing, 0u) << what;
      EXPECT_EQ(c.shadow_hw.failures(), 0u) << what;
      // auto draws the pages with the compute raster: the compared pages are bit-identical.
      if (mode == GpuRasterMode::kAuto) {
        EXPECT_EQ(c.shadow_hw.count(HwPixel::kIdentical), c.shadow_pages_compared * kShadowPageTexels * kShadowPageTexels)
            << what;
      }
      EXPECT_TRUE(c.holds()) << what << ": max channel diff " << c.max_channel_diff << ", hw failures "
                             << c.hw.failures();
    }
  testing::expect_no_validation_messages(*gpu);
}

}  // namespace
}  // namespace vgeo
