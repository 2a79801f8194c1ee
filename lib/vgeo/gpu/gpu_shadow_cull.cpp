// The shadow views' multi-view cull on the device (gpu_frame.h cull_shadow_views_vulkan; the
// decisions are shaders/shadow_cull.comp, the reference's cull_shadow_views in its arithmetic).
// The host writes the frame's records (maps, views, the instances' world spheres, the double
// object→light matrix per (view, instance) pair, each view's pages-to-draw table), records the
// instance pass, the dispatch arguments and the cluster pass in one submission, and reads the
// outputs back; the elements stay where the shadow raster reads them.
// Based on: Karis et al., "Nanite: A Deep Dive" (SIGGRAPH 2021), §"Multi-view rendering",
// §"Culling and addressing to pages".
#include <algorithm>
#include <cstddef>
#include <cstring>

#include "vgeo/core/error.h"
#include "vgeo/cull/view.h"
#include "vgeo/gpu/gpu_renderer.h"
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shader_records.h"

namespace vgeo {

using namespace gpu_detail;

namespace {

// Loop back edges of one invocation besides its page loop: sphere_texel_rect's 8 corners and
// the instance pass's work-item loop (one per 64 clusters of a mesh, added per scene), with
// room for the loops the compiler keeps; the page loop visits ≤ side² pages of a mip
// (16,384 at mip 0 of the spec's 128² page table). Checked against kGpuLoopBudget (llvmpipe's
// per-invocation loop limit, core/cull_shared.h) less the cull passes' own margin.
constexpr uint64_t kShadowCullLoopOverhead = 64;
constexpr uint64_t kShadowCullLoopBudget = kGpuLoopBudget - 1024;
// First element capacity of a renderer (grown to what a frame needed, rounded up to a power of
// two, and kept): 64 Ki elements, 512 KiB of GpuVisibleCluster.
constexpr uint32_t kInitialElementCapacity = 1u << 16;

template <class T>
void put_records(GpuRenderer& r, GpuBuffer& b, const std::vector<T>& data, const char* what) {
  const uint64_t bytes = std::max<uint64_t>(data.size() * sizeof(T), 4);
  check_buffer_range(*r.gpu, bytes, what);
  ensure_size(*r.gpu, b, bytes);
  if (!data.empty()) std::memcpy(b.mapped, data.data(), data.size() * sizeof(T));
}

uint32_t cull_blocks_of(uint32_t clusters) { return (clusters + kGpuShadowCullGroupSize - 1) / kGpuShadowCullGroupSize; }

// The frame's records for shadow_cull.comp (everything but the maps and the outputs).
struct ShadowCullRecords {
  std::vector<GpuShadowCullView> views;
  std::vector<GpuShadowCullInstance> instances;
  std::vector<GpuCullInstance> pairs;
  std::vector<int32_t> draw_of_page;
  uint64_t work_items = 0;  // every pair kept: the work buffer's capacity
};
ShadowCullRecords make_shadow_cull_records(const RenderScene& scene, const ShadowFrame& frame, const ShadowDrawPlan& plan) {
  ShadowCullRecords out;
  const size_t n = scene.instances.size();
  uint64_t blocks_per_view = 0;
  std::vector<double> scale(n);
  out.instances.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const CullInstance& inst = scene.instances[i];
    Vec3d c;
    double radius;
    shadow_instance_sphere(scene.meshes, inst, &c, &radius);
    out.instances[i] = {{c.x, c.y, c.z}, radius};
    scale[i] = max_axis_scale(inst.object_to_world);
    blocks_per_view += cull_blocks_of(uint32_t(scene.meshes[inst.mesh].clusters.size()));
  }
  out.work_items = blocks_per_view * plan.views.size();
  out.pairs.reserve(plan.views.size() * n);
  for (const ShadowView& v : plan.views) {
    GpuShadowCullView g{};
    g.texel = v.texel;
    g.map = v.map;
    g.r_m = v.r_m;
    g.side = v.side;
    g.page_offset = uint32_t(out.draw_of_page.size());
    g.pixels_per_unit_at_1 = v.pixels_per_unit_at_1;
    g.lod_z_near = v.lod_z_near;
    g.tau_s = v.tau_s;
    out.views.push_back(g);
    out.draw_of_page.insert(out.draw_of_page.end(), v.draw_of_page.begin(), v.draw_of_page.end());
    for (size_t i = 0; i < n; ++i) {
      GpuCullInstance p{};
      const Mat4d o2l = shadow_object_to_light(frame, v.map, scene.instances[i]);
      std::memcpy(p.object_to_view, o2l.m, sizeof p.object_to_view);
      p.scale = scale[i];
      p.mesh = scene.instances[i].mesh;
      out.pairs.push_back(p);
    }
  }
  return out;
}

// Fails when one invocation could run past the device's loop budget.
void check_shadow_cull_loop_bound(const GpuContext& gpu, const RenderScene& scene, const ShadowDrawPlan& plan) {
  uint64_t pages = 0, blocks = 0;
  for (const ShadowView& v : plan.views) pages = std::max<uint64_t>(pages, uint64_t(v.side) * v.side);
  for (const ClusterDag& dag : scene.meshes) blocks = std::max<uint64_t>(blocks, cull_blocks_of(uint32_t(dag.clusters.size())));
  if (kShadowCullLoopOverhead + pages + blocks > kShadowCullLoopBudget)
    fail("GPU_SCENE_TOO_LARGE", gpu.device_name,
         "one shadow-cull invocation may visit " + std::to_string(pages) + " pages and " + std::to_string(blocks) +
             " work items, more than the device's loop budget per invocation (" +
             std::to_string(kShadowCullLoopBudget) + ")",
         kExitUsage);
}

std::vector<const GpuBuffer*> shadow_cull_bindings(GpuRenderer& r) {
  return gpu_bindings(kShadowCullBindingCount, {{kShadowCullBindMeshes, &r.cull_meshes.meshes},
                                                {kShadowCullBindClusters, &r.cull_meshes.clusters},
                                                {kShadowCullBindStream, &r.cull_meshes.stream},
                                                {kShadowCullBindMaps, &r.shadow_maps},
                                                {kShadowCullBindViews, &r.shadow_cull_views},
                                                {kShadowCullBindInstances, &r.shadow_cull_instances},
                                                {kShadowCullBindViewInstances, &r.shadow_cull_pairs},
                                                {kShadowCullBindDrawOfPage, &r.shadow_draw_of_page},
                                                {kShadowCullBindWork, &r.shadow_cull_work},
                                                {kShadowCullBindElements, &r.shadow_elements},
                                                {kShadowCullBindElementPage, &r.shadow_element_page},
                                                {kShadowCullBindProvisional, &r.shadow_provisional},
                                                {kShadowCullBindRequests, &r.shadow_requests}});
}

}  // namespace

namespace gpu_detail {

void put_rows(const Mat4d& m, double* out, int rows) {
  for (int row = 0; row < rows; ++row)
    for (int col = 0; col < 4; ++col) out[4 * row + col] = m.at(row, col);
}

void upload_shadow_maps(GpuRenderer& r, const ShadowFrame* shadows) {
  std::vector<GpuShadowMap> maps(shadows ? std::max<size_t>(shadows->maps.size(), 1) : 1);
  for (size_t k = 0; shadows && k < shadows->maps.size(); ++k) {
    const ShadowMapView& m = shadows->maps[k];
    GpuShadowMap& g = maps[k];
    g = {};
    put_rows(m.world_to_light, g.world_to_light, 3);
    put_rows(m.light_to_clip, g.light_to_clip, 4);
    g.eye[0] = m.eye.x, g.eye[1] = m.eye.y, g.eye[2] = m.eye.z;
    g.tan_half = m.tan_half;
    g.z_near = m.z_near;
    g.side = m.side;
    g.depth_range = m.depth_range;
    g.type = uint32_t(m.type);
    g.ortho = m.ortho ? 1u : 0u;
    g.table_offset = m.table_offset;
  }
  put_records(r, r.shadow_maps, maps, "the lit view's lights and shadow maps");
}

}  // namespace gpu_detail

GpuShadowCull cull_shadow_views_vulkan(GpuRenderer& r, const RenderScene& scene, const ShadowFrame& frame,
                                       const ShadowDrawPlan& plan, const std::vector<std::vector<uint8_t>>* usable) {
  GpuContext& gpu = *r.gpu;
  GpuShadowCull out;
  const size_t draws = plan.pages.size();
  out.list.clusters.assign(draws, {});
  out.list.provisional.assign(draws, 0);
  if (draws == 0) return out;
  check_shadow_cull_loop_bound(gpu, scene, plan);
  const ShadowCullRecords records = make_shadow_cull_records(scene, frame, plan);
  const uint64_t pairs = records.pairs.size();
  if (pairs > uint64_t(kGpuMaxGroupsX) * kGpuShadowCullGroupSize || records.work_items > UINT32_MAX / 2)
    fail("GPU_SCENE_TOO_LARGE", gpu.device_name,
         std::to_string(pairs) + " (shadow view, instance) pairs, more than one shadow-cull dispatch addresses",
         kExitUsage);
  upload_shadow_maps(r, &frame);
  put_records(r, r.shadow_cull_views, records.views, "the shadow cull's views");
  put_records(r, r.shadow_cull_instances, records.instances, "the shadow cull's instances");
  put_records(r, r.shadow_cull_pairs, records.pairs, "the shadow cull's (view, instance) pairs");
  put_records(r, r.shadow_draw_of_page, records.draw_of_page, "the shadow cull's pages to draw");
  const uint64_t work_bytes = sizeof(GpuShadowCullHeader) + records.work_items * 2 * sizeof(uint32_t);
  check_buffer_range(gpu, work_bytes, "the shadow cull's work items");
  ensure_size(gpu, r.shadow_cull_work, work_bytes);
  put_records(r, r.shadow_provisional, std::vector<uint32_t>(draws, 0u), "the shadow cull's provisional pages");
  uint64_t groups = 0;
  for (const GpuCullMesh& m : r.cull_meshes.table) groups += m.group_count;
  put_records(r, r.shadow_requests, std::vector<uint32_t>(groups, 0u), "the shadow cull's requests");
  // Streaming: the usable groups recomputed after stream_end (the primary passes are done with
  // the stream words' usable flags of stream_begin).
  if (usable) write_cull_usable(r.cull_meshes, *usable);

  GpuShadowCullPush push{};
  push.pair_count = uint32_t(pairs);
  push.instance_count = uint32_t(scene.instances.size());
  push.streamed = usable ? 1u : 0u;
  push.tau = frame.options.threshold_px;
  push.work_capacity = uint32_t(records.work_items);
  if (r.shadow_element_capacity == 0) r.shadow_element_capacity = kInitialElementCapacity;
  GpuShadowCullHeader* header = r.shadow_cull_work.data<GpuShadowCullHeader>();
  GpuRecorder& rec = *r.recorder;
  for (;;) {  // at most twice: the second run has the capacity the first one counted
    const uint64_t capacity = r.shadow_element_capacity;
    check_buffer_range(gpu, capacity * sizeof(GpuVisibleCluster), "the shadow raster's elements");
    ensure_size(gpu, r.shadow_elements, capacity * sizeof(GpuVisibleCluster));
    ensure_size(gpu, r.shadow_element_page, capacity * sizeof(uint32_t));
    push.element_capacity = uint32_t(capacity);
    *header = {};
    begin_commands(rec);
    const uint32_t t0 = cmd_timestamp(rec);
    push.mode = kShadowCullInstances;
    cmd_dispatch(rec, r.shadow_cull, shadow_cull_bindings(r), &push,
                 uint32_t((pairs + kGpuShadowCullGroupSize - 1) / kGpuShadowCullGroupSize));
    push.mode = kShadowCullArgs;
    cmd_dispatch(rec, r.shadow_cull, shadow_cull_bindings(r), &push, 1);
    push.mode = kShadowCullClusters;
    cmd_dispatch_indirect(rec, r.shadow_cull, shadow_cull_bindings(r), &push, r.shadow_cull_work,
                          offsetof(GpuShadowCullHeader, dispatch_x));
    const uint32_t t1 = cmd_timestamp(rec);
    submit_and_wait(rec);
    out.ms += timestamp_ms(rec, t0, t1);
    if (header->element_count <= capacity) break;
    uint32_t grown = kInitialElementCapacity;
    while (grown < header->element_count && grown < (1u << 31)) grown *= 2;
    r.shadow_element_capacity = std::max(grown, header->element_count);
    std::memset(r.shadow_provisional.mapped, 0, draws * sizeof(uint32_t));  // rerun from clean outputs
    std::memset(r.shadow_requests.mapped, 0, std::max<uint64_t>(groups, 1) * sizeof(uint32_t));
  }
  const uint32_t count = header->element_count;
  out.pairs_kept = 0;
  const uint32_t* items = reinterpret_cast<const uint32_t*>(header + 1);
  for (uint32_t k = 0; k < header->work_count; ++k) out.pairs_kept += items[2 * k + 1] == 0;  // block 0 once per pair
  const GpuVisibleCluster* elements = r.shadow_elements.data<GpuVisibleCluster>();
  const uint32_t* element_page = r.shadow_element_page.data<uint32_t>();
  out.elements.assign(elements, elements + count);
  out.element_page.assign(element_page, element_page + count);
  const uint32_t n = uint32_t(scene.instances.size());
  for (uint32_t e = 0; e < count; ++e)
    out.list.clusters[element_page[e]].push_back({elements[e].instance % n, elements[e].cluster});
  for (auto& clusters : out.list.clusters) std::sort(clusters.begin(), clusters.end());
  const uint32_t* provisional = r.shadow_provisional.data<uint32_t>();
  for (size_t d = 0; d < draws; ++d) out.list.provisional[d] = provisional[d] != 0 ? 1 : 0;
  if (usable) {
    const uint32_t* words = r.shadow_requests.data<uint32_t>();
    for (uint32_t k = 0; k < r.cull_meshes.table.size(); ++k) {
      const GpuCullMesh& m = r.cull_meshes.table[k];
      for (uint32_t g = 0; g < m.group_count; ++g) {
        const uint32_t w = words[m.first_group + g];
        if (w == 0) continue;
        const uint32_t bits = w - 1;
        float priority;
        std::memcpy(&priority, &bits, sizeof priority);
        out.list.requests.push_back({k, g, priority});
      }
    }
  }
  return out;
}

}  // namespace vgeo
