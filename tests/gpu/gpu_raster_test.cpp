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
  MemoryFormScene ms = make_memory_form_scene(sf.scene);
  GpuRendererPtr renderer = create_gpu_renderer(*gpu, ms);
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
    render_frame(ms.scene, cameras[i], settings, pool, nullptr, &cpu);
    render_frame_vulkan(*renderer, ms, cameras[i], settings, pool, nullptr, &vk);
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
