// The shadow views' multi-view cull on the device (shaders/shadow_cull.comp, spec/shadow.md §8)
// against the reference's cull_shadow_views on the same plan (the same cache, allocation and
// views): per page the same set of (instance, cluster) elements, the same provisional pages and
// the same requests (the Streamer's reduction: the highest priority per (mesh, group)), on the
// directional, spot and point example scenes, uncached and cached (a caster moved: only the
// pages it overlaps are redrawn), unstreamed and streamed (partial residency masks).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <map>
#include <utility>

#include "gpu/gpu_testing.h"
#include "support/paths.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/gpu/gpu_renderer.h"
#include "vgeo/render/frame.h"
#include "vgeo/render/scene_file.h"

namespace vgeo {
namespace {

SceneFile load_cull_scene(const char* name) {
  return load_scene_file((test::source_dir() / "tests" / "shadow" / "scenes" / name).string(), {});
}

ShadowFrame marked_cull_frame(const RenderScene& scene, const Camera& camera, ThreadPool& pool, const ShadowOptions& options) {
  RenderSettings settings;
  settings.shade = false;
  Frame primary;
  render_frame(FrameInputs{scene, camera, settings, pool, nullptr, false}, &primary);
  ShadowFrame frame = make_shadow_frame(scene.lights, shadow_scene_bounds(scene.meshes, scene.instances),
                                        camera.position, options);
  mark_shadow_pages(primary.vis, primary.view, scene.lights, pool, &frame);
  return frame;
}

// cull_shadow_views' request list reduced as the Streamer reads it (Streamer::end_frame: the
// highest priority per (mesh, group)), ascending.
std::vector<GroupRequest> reduced(const std::vector<GroupRequest>& requests) {
  std::map<std::pair<uint32_t, uint32_t>, float> best;
  for (const GroupRequest& r : requests) {
    auto [it, added] = best.try_emplace({r.mesh, r.group}, r.priority);
    if (!added) it->second = std::max(it->second, r.priority);
  }
  std::vector<GroupRequest> out;
  for (const auto& [key, priority] : best) out.push_back({key.first, key.second, priority});
  return out;
}

struct CullCounts {
  uint64_t elements = 0, provisional = 0, requests = 0;
};

// One plan culled by both; everything the cull decides must agree. Returns the CPU's counts.
CullCounts expect_same_cull(GpuRenderer& renderer, const RenderScene& scene, const ShadowFrame& frame,
                            const ShadowDrawPlan& plan, const std::vector<std::vector<uint8_t>>* usable,
                            ThreadPool& pool, const std::string& what) {
  ShadowDrawList cpu;
  cull_shadow_views(scene.meshes, scene.instances, frame, plan, usable, pool, &cpu);
  const GpuShadowCull gpu = cull_shadow_views_vulkan(renderer, scene, frame, plan, usable);
  CullCounts counts;
  EXPECT_EQ(cpu.clusters.size(), gpu.list.clusters.size()) << what;
  size_t pages_differing = 0, first = 0;
  for (size_t d = 0; d < std::min(cpu.clusters.size(), gpu.list.clusters.size()); ++d) {
    counts.elements += cpu.clusters[d].size();
    if (cpu.clusters[d] != gpu.list.clusters[d] && pages_differing++ == 0) first = d;
  }
  EXPECT_EQ(pages_differing, 0u) << what << ": first differing page " << first << " (cpu "
                                 << cpu.clusters[first].size() << " elements, vulkan "
                                 << gpu.list.clusters[first].size() << ")";
  // The device's own element list (what the raster reads): as many elements, each page named.
  EXPECT_EQ(gpu.elements.size(), counts.elements) << what;
  EXPECT_EQ(gpu.element_page.size(), gpu.elements.size()) << what;
  EXPECT_EQ(cpu.provisional, gpu.list.provisional) << what;
  for (uint8_t p : cpu.provisional) counts.provisional += p;
  const std::vector<GroupRequest> expected = reduced(cpu.requests);
  EXPECT_EQ(expected.size(), gpu.list.requests.size()) << what;
  size_t requests_differing = 0;
  for (size_t k = 0; k < std::min(expected.size(), gpu.list.requests.size()); ++k) {
    const GroupRequest &a = expected[k], &b = gpu.list.requests[k];
    requests_differing += a.mesh != b.mesh || a.group != b.group || a.priority != b.priority;  // bitwise equal floats
  }
  EXPECT_EQ(requests_differing, 0u) << what;
  counts.requests = expected.size();
  std::printf("%s: %zu pages, %zu views, %llu elements, %llu pairs kept, %llu provisional, %llu requests, %.2f ms\n",
              what.c_str(), plan.pages.size(), plan.views.size(), (unsigned long long)counts.elements,
              (unsigned long long)gpu.pairs_kept, (unsigned long long)counts.provisional,
              (unsigned long long)counts.requests, gpu.ms);
  return counts;
}

// Partial residency for every mesh but the last (which does not stream: empty mask): a fixed
// pattern that leaves some of every level's groups unusable, so the resident rule draws coarser
// clusters; and every other group the ideal cut requests over the pages to draw (named by a
// cull with every group usable), so some ideal-cut cluster is never drawn and pages turn
// provisional whatever the DAG's shape (the pattern alone missed the spot scene's ideal cut
// once the builder changed).
std::vector<std::vector<uint8_t>> partial_residency(const RenderScene& scene, const ShadowFrame& frame,
                                                    const ShadowDrawPlan& plan, ThreadPool& pool) {
  std::vector<std::vector<uint8_t>> usable(scene.meshes.size()), every(scene.meshes.size());
  for (size_t m = 0; m + 1 < scene.meshes.size(); ++m) {
    const ClusterDag& dag = scene.meshes[m];
    usable[m].resize(dag.groups.size());
    every[m].assign(dag.groups.size(), 1);
    for (size_t g = 0; g < dag.groups.size(); ++g) usable[m][g] = (g * 7 + m) % 3 != 0 ? 1 : 0;
  }
  ShadowDrawList ideal;
  cull_shadow_views(scene.meshes, scene.instances, frame, plan, &every, pool, &ideal);
  const std::vector<GroupRequest> wanted = reduced(ideal.requests);
  for (size_t k = 0; k < wanted.size(); k += 2)
    if (wanted[k].mesh + 1 < scene.meshes.size()) usable[wanted[k].mesh][wanted[k].group] = 0;
  return usable;
}

TEST(GpuShadowCull, ElementsPerPageEqualTheCpuCullOnTheExampleScenes) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  ThreadPool pool(2);
  for (const char* name : {"directional.json", "spot.json", "point.json"}) {
    SceneFile sf = load_cull_scene(name);
    RenderScene scene = sf.scene;
    GpuRendererPtr renderer = create_gpu_renderer(*gpu, scene, memory_form_pages(sf));
    // Uncached: every marked page is drawn.
    ShadowFrame frame = marked_cull_frame(scene, sf.cameras[0], pool, {});
    ShadowCache cache;
    ShadowDrawPlan plan = plan_shadow_draw(scene.meshes, scene.instances, scene.lights, &frame, &cache);
    ASSERT_GT(plan.pages.size(), 1u) << name;
    const CullCounts all = expect_same_cull(*renderer, scene, frame, plan, nullptr, pool, std::string(name) + " uncached");
    EXPECT_GT(all.elements, plan.pages.size()) << name;
    EXPECT_EQ(all.provisional + all.requests, 0u) << name;  // not streamed
    // Element buffers too small for the frame: the cull counts, grows them and runs again.
    renderer->shadow_element_capacity = 16;
    expect_same_cull(*renderer, scene, frame, plan, nullptr, pool, std::string(name) + " uncached, buffers grown");
    EXPECT_GE(renderer->shadow_element_capacity, all.elements) << name;
    // Streamed: the resident cut, provisional pages and requests.
    const std::vector<std::vector<uint8_t>> usable = partial_residency(scene, frame, plan, pool);
    const CullCounts streamed = expect_same_cull(*renderer, scene, frame, plan, &usable, pool, std::string(name) + " streamed");
    EXPECT_GT(streamed.provisional, 0u) << name;
    EXPECT_GT(streamed.requests, 0u) << name;
    // Cached: finish the frame (the cache keeps its pages), move a caster; the next plan
    // redraws the pages the caster overlaps.
    ShadowDrawList list;
    cull_shadow_views(scene.meshes, scene.instances, frame, plan, nullptr, pool, &list);
    finish_shadow_cull(scene.instances, std::move(plan), &frame, &cache, &list);
    end_shadow_draw(scene.instances, scene.lights, &frame, &cache, true);
    scene.instances[3].object_to_world.at(0, 3) += 0.2;
    ShadowFrame next = marked_cull_frame(scene, sf.cameras[0], pool, {});
    ShadowDrawPlan cached = plan_shadow_draw(scene.meshes, scene.instances, scene.lights, &next, &cache);
    EXPECT_GT(next.pages_cached, 0u) << name;
    ASSERT_GT(cached.pages.size(), 0u) << name;
    expect_same_cull(*renderer, scene, next, cached, nullptr, pool, std::string(name) + " cached, caster moved");
  }
  testing::expect_no_validation_messages(*gpu);
}

// Texel density b = 2 (spec/shadow.md §4: four texels per pixel side, finer mips, more pages):
// the device cull's elements equal the CPU's, and the whole draw (marks on the CPU, cull and
// raster on the device) writes a pool bit-identical to draw_shadow_pages.
TEST(GpuShadowCull, DenserTexelsKeepThePagesBitIdentical) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  ThreadPool pool(2);
  ShadowOptions options;
  options.texels_per_pixel_log2 = 2;
  for (const char* name : {"directional.json", "spot.json"}) {
    SceneFile sf = load_cull_scene(name);
    GpuRendererPtr renderer = create_gpu_renderer(*gpu, sf.scene, memory_form_pages(sf));
    ShadowFrame base = marked_cull_frame(sf.scene, sf.cameras[0], pool, {});
    ShadowFrame cpu = marked_cull_frame(sf.scene, sf.cameras[0], pool, options);
    EXPECT_GT(cpu.pages_marked, base.pages_marked) << name << ": denser texels mark more pages";
    ShadowFrame vk = cpu;
    draw_shadow_pages(sf.scene.meshes, sf.scene.instances, sf.scene.lights, pool, &cpu, nullptr);
    draw_shadow_pages_vulkan(*renderer, sf.scene, pool, &vk, nullptr);
    EXPECT_EQ(cpu.page_table, vk.page_table) << name;
    EXPECT_EQ(shadow_frame_stats(cpu), shadow_frame_stats(vk)) << name;
    ASSERT_EQ(cpu.own_texels.size(), vk.own_texels.size()) << name;
    size_t differing = 0, written = 0;
    for (size_t i = 0; i < cpu.own_texels.size(); ++i) {
      uint32_t a, b;
      std::memcpy(&a, &cpu.own_texels[i], 4);
      std::memcpy(&b, &vk.own_texels[i], 4);
      differing += a != b;
      written += a != 0;
    }
    EXPECT_EQ(differing, 0u) << name;
    EXPECT_GT(written, 0u) << name << ": no texel drawn, the comparison would prove nothing";
    ASSERT_TRUE(cpu.drawn && vk.drawn) << name;
    EXPECT_EQ(cpu.drawn->clusters, vk.drawn->clusters) << name;
  }
  testing::expect_no_validation_messages(*gpu);
}

}  // namespace
}  // namespace vgeo
