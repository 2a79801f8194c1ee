// The compute rasterizer against the CPU reference: both render the decoded memory form of
// the same scene; every visibility-buffer key must be bit-identical (spec/raster.md
// §Backends agree). Cameras cover the orbit, clipping at the near plane and the guard band.
#include <gtest/gtest.h>

#include "gpu/gpu_testing.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/render/scene_file.h"

namespace vgeo {
namespace {

struct KeyDiff {
  uint64_t differing = 0;
  size_t first = 0;
};
KeyDiff diff_keys(const VisBuffer& a, const VisBuffer& b) {
  KeyDiff d;
  for (size_t i = 0; i < a.keys.size(); ++i)
    if (a.keys[i] != b.keys[i] && d.differing++ == 0) d.first = i;
  return d;
}

TEST(GpuRaster, DefaultSceneBitIdenticalToCpu) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  SceneFile sf = make_default_scene(96, 64, 4, SceneLoadOptions{});
  GpuRendererPtr renderer = create_gpu_renderer(*gpu, sf.scene, memory_form_pages(sf));
  ThreadPool pool(2);
  RenderSettings settings = sf.settings;
  settings.shade = false;
  std::vector<Camera> cameras = sf.path;
  cameras.push_back(sf.cameras[0]);
  // A camera inside the scene with a large near plane: triangles cross the near plane.
  Camera inside = sf.cameras[0];
  inside.position = {0.2, 0.3, 0.4};
  inside.z_near = 0.5;
  cameras.push_back(inside);
  for (size_t i = 0; i < cameras.size(); ++i) {
    Frame cpu, vk;
    render_frame({sf.scene, cameras[i], settings, pool, nullptr}, &cpu);
    render_frame_vulkan(*renderer, {sf.scene, cameras[i], settings, pool, nullptr}, &vk);
    ASSERT_EQ(cpu.visible, vk.visible) << "camera " << i;
    KeyDiff d = diff_keys(cpu.vis, vk.vis);
    uint64_t covered = 0;
    for (uint64_t k : cpu.vis.keys) covered += k != 0;
    EXPECT_GT(covered, 0u) << "camera " << i;
    EXPECT_EQ(d.differing, 0u) << "camera " << i << ": first at pixel " << d.first << " cpu " << std::hex
                               << cpu.vis.keys[d.first] << " gpu " << vk.vis.keys[d.first];
  }
  testing::expect_no_validation_messages(*gpu);
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

TEST(GpuShade, EveryViewWithinOneOf255) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  SceneFile sf = make_default_scene(96, 64, 1, SceneLoadOptions{});
  GpuRendererPtr renderer = create_gpu_renderer(*gpu, sf.scene, memory_form_pages(sf));
  ThreadPool pool(2);
  for (ShadeView view : {ShadeView::kLit, ShadeView::kTriangle, ShadeView::kCluster, ShadeView::kGroup, ShadeView::kLod,
                         ShadeView::kError, ShadeView::kOverdraw}) {
    RenderSettings settings = sf.settings;
    settings.view = view;
    Frame cpu, vk;
    render_frame({sf.scene, sf.cameras[0], settings, pool, nullptr}, &cpu);
    render_frame_vulkan(*renderer, {sf.scene, sf.cameras[0], settings, pool, nullptr}, &vk);
    ASSERT_EQ(cpu.image.rgb.size(), vk.image.rgb.size());
    int max_diff = 0;
    uint64_t over = 0, differing = 0;
    for (size_t i = 0; i < cpu.image.rgb.size(); ++i) {
      int d = std::abs(int(cpu.image.rgb[i]) - int(vk.image.rgb[i]));
      max_diff = std::max(max_diff, d);
      over += d > 1;
      differing += d != 0;
    }
    EXPECT_LE(max_diff, 1) << shade_view_name(view) << ": " << over << " channels over 1/255";
    EXPECT_NE(vk.stats.find("shade"), nullptr);
    std::printf("view %-9s channels differing by 1/255: %llu of %zu\n", shade_view_name(view),
                (unsigned long long)differing, cpu.image.rgb.size());
  }
  testing::expect_no_validation_messages(*gpu);
}

}  // namespace
}  // namespace vgeo
