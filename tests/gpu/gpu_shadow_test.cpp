// Virtual shadow pages on Vulkan against the CPU reference (spec/shadow.md §5): from the same
// marked pages, draw_shadow_pages_vulkan allocates the same slots, reuses the same cached pages
// and writes every physical pool texel bit-identical to draw_shadow_pages, on the three example
// light scenes and over two frames with a moving caster and a moving light.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "gpu/gpu_testing.h"
#include "support/paths.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/render/compare.h"
#include "vgeo/render/frame.h"
#include "vgeo/render/scene_file.h"

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

}  // namespace
}  // namespace vgeo
