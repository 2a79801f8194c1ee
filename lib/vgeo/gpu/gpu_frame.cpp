// Vulkan frame executor (gpu_frame.h, spec/gpu.md §Frame): the frame plan's steps on the device,
// the raster passes alone (raster_visible_vulkan) and the shade pass.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Culling Dataflow" (two-pass
// occlusion against the previous frame's HZB); the visibility buffer of Burns, Hunt, JCGT 2(2), 2013.
#include "vgeo/gpu/gpu_frame.h"

#include <algorithm>
#include <chrono>
#include <cassert>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "vgeo/core/error.h"
#include "vgeo/core/lod.h"
#include "vgeo/render/streaming.h"
#include "vgeo/gpu/gpu_renderer.h"
#include "vgeo/gpu/shader_records.h"
#include "vgeo/gpu/shaders.h"

namespace vgeo {

using namespace gpu_detail;

namespace {

constexpr uint32_t kShadeGroupSize = 64;  // shaders/shade.comp local_size_x

// Rasterizes visible[first, first + count) into the vis buffer by the renderer's raster mode
// (hw_raster.h); returns the GPU time and the pixels written, adds the split to `split`.
void raster_range(GpuRenderer& r, uint32_t width, uint32_t height, float z_near, float pixels_per_unit_at_1,
                  bool cull_backfaces, uint32_t first, uint32_t count, PassStats* stats, RasterSplitStats* split) {
  GpuRecorder& rec = *r.recorder;
  begin_commands(rec);
  cmd_fill(rec, r.counters, 0);
  GpuRasterRequest request;
  request.mode = r.options.raster;
  request.first_visible = first;
  request.visible_count = count;
  request.width = width;
  request.height = height;
  request.z_near = z_near;
  request.pixels_per_unit_at_1 = pixels_per_unit_at_1;
  request.hw_min_triangle_area_px = r.options.hw_min_triangle_area_px;
  request.cull_backfaces = cull_backfaces;
  uint32_t t0 = cmd_timestamp(rec);
  const GpuRasterBuffers buffers{geometry(r), &r.counters};
  record_gpu_raster(rec, *r.raster, buffers, request);
  RasterSplitStats tiled;
  if (request.mode != GpuRasterMode::kHw) {
    continue_commands(rec);  // the host cuts the deferred big triangles into tiles (spec/raster.md §13.5)
    record_gpu_raster_tiles(rec, *r.raster, buffers, request, &tiled);
  }
  uint32_t t1 = cmd_timestamp(rec);
  submit_and_wait(rec);
  stats->ms = timestamp_ms(rec, t0, t1);
  stats->pixels_written = r.counters.data<uint64_t>()[0];
  split->add(read_gpu_raster_split(*r.raster));
  split->add(tiled);
  // Never a silently wrong image: the compute rasterizer flags triangles whose pixel loops
  // did not run to their end (spec/raster.md §13.5: unreachable with tiles of
  // kGpuRasterTileSize, kept as the guard); the hardware path has no such loop.
  const uint32_t overflow = r.counters.data<uint32_t>()[kGpuRasterOverflowWord];
  if (overflow != 0)
    fail("GPU_SCENE_TOO_LARGE", r.gpu->device_name,
         std::to_string(overflow) + " triangle(s) needed more pixel-loop iterations than the compute rasterizer's "
             "loop budget (" + std::to_string(kGpuLoopBudget - kGpuRasterLoopMargin) +
             " per invocation, spec/raster.md §13.5): use --raster hw or auto",
         kExitUsage);
}

// Uploads the per-frame raster inputs and clears the visibility buffer.
void upload_raster_inputs(GpuRenderer& r, const std::vector<Mat4>& object_to_clip, const std::vector<uint32_t>& mesh,
                          const std::vector<float>& instance_scale, const std::vector<VisibleCluster>& visible,
                          uint32_t width, uint32_t height) {
  GpuContext& gpu = *r.gpu;
  std::vector<GpuInstance> instances(object_to_clip.size());
  for (size_t i = 0; i < instances.size(); ++i) {
    std::memcpy(instances[i].object_to_clip, object_to_clip[i].m, sizeof(instances[i].object_to_clip));
    instances[i].mesh = mesh[i];
  }
  ensure_size(gpu, r.instances, instances.size() * sizeof(GpuInstance));
  if (!instances.empty()) std::memcpy(r.instances.mapped, instances.data(), instances.size() * sizeof(GpuInstance));
  static_assert(sizeof(VisibleCluster) == sizeof(GpuVisibleCluster));
  ensure_size(gpu, r.visible, visible.size() * sizeof(GpuVisibleCluster));
  if (!visible.empty()) std::memcpy(r.visible.mapped, visible.data(), visible.size() * sizeof(GpuVisibleCluster));
  prepare_gpu_raster(*r.raster, instance_scale, uint32_t(visible.size()));
  const uint64_t vis_bytes = uint64_t(width) * height * 8;
  check_buffer_range(gpu, vis_bytes, "the visibility buffer");
  ensure_size(gpu, r.vis, vis_bytes);
  std::memset(r.vis.mapped, 0, vis_bytes);
}

static_assert(kGpuShadowPageTexels == kShadowPageTexels);
constexpr size_t kShadowPageTexelCount = size_t(kShadowPageTexels) * kShadowPageTexels;

// The shadow raster's inputs besides the elements, which the device's cull left in
// r.shadow_elements and r.shadow_element_page (instance field: the (view, instance) pair): a
// GpuInstance per pair (the view's float object→clip), the pages drawn, the page table, and
// what the hardware path's draws need on the host.
struct ShadowElements {
  uint32_t count = 0;
  std::vector<GpuShadowPage> pages;
  std::vector<GpuShadowHwDraw> hw_draws;  // one per element, page by page
};
ShadowElements upload_shadow_raster_inputs(GpuRenderer& r, const RenderScene& scene, const ShadowFrame& frame,
                                           const ShadowDrawList& list, const GpuShadowCull& cull) {
  GpuContext& gpu = *r.gpu;
  ShadowElements out;
  out.pages.resize(list.pages.size());
  for (size_t d = 0; d < list.pages.size(); ++d) {
    const ShadowPageDraw& p = list.pages[d];
    const uint32_t table_offset = uint32_t(shadow_page_entry(frame, ShadowTexel{p.map, p.mip, 0, 0, 0}));
    out.pages[d] = {p.raster.virtual_width, p.raster.window_x,  p.raster.window_y,
                    p.slot,                 p.raster.z_near,    table_offset,
                    frame.options.pages_per_side >> p.mip, 0};
  }
  const size_t n = scene.instances.size();
  std::vector<GpuInstance> instances(list.object_to_clip.size() * n);
  for (size_t v = 0; v < list.object_to_clip.size(); ++v)
    for (size_t i = 0; i < n; ++i) {
      GpuInstance& g = instances[v * n + i];
      std::memcpy(g.object_to_clip, list.object_to_clip[v][i].m, sizeof(g.object_to_clip));
      g.mesh = scene.instances[i].mesh;
    }
  out.count = uint32_t(cull.elements.size());
  // An element's index is the key's visible-cluster field (raster.glsl's big-triangle ids).
  if (cull.elements.size() > kMaxVisibleClusters)
    fail("GPU_SCENE_TOO_LARGE", gpu.device_name,
         std::to_string(cull.elements.size()) + " cluster-page draws of the shadow pages, more than one raster pass "
             "addresses (" + std::to_string(kMaxVisibleClusters) + ")",
         kExitUsage);
  for (uint32_t e = 0; e < out.count; ++e) {
    const GpuVisibleCluster& c = cull.elements[e];
    out.hw_draws.push_back({e, scene.meshes[scene.instances[c.instance % n].mesh].clusters[c.cluster].triangle_count,
                            cull.element_page[e]});
  }
  std::stable_sort(out.hw_draws.begin(), out.hw_draws.end(),
                   [](const GpuShadowHwDraw& a, const GpuShadowHwDraw& b) { return a.page < b.page; });
  auto put = [&](GpuBuffer& b, const auto& data) {
    const uint64_t bytes = data.size() * sizeof(data[0]);
    check_buffer_range(gpu, bytes, "the shadow raster's inputs");
    ensure_size(gpu, b, std::max<uint64_t>(bytes, 4));
    if (bytes) std::memcpy(b.mapped, data.data(), bytes);
  };
  put(r.shadow_instances, instances);
  put(r.shadow_pages, out.pages);
  put(r.shadow_table, frame.page_table);
  return out;
}

// Draws the listed pages into r.shadow_pool (already holding the pool, drawn slots cleared):
// the compute rasterizer (bit-identical to the CPU), or with `hardware` the hardware raster
// through the page table (spec/shadow.md §8).
void raster_shadow_pages(GpuRenderer& r, const ShadowElements& elements, bool hardware) {
  const uint32_t element_count = elements.count;
  GpuRecorder& rec = *r.recorder;
  const GpuGeometryBuffers g{&r.pages, &r.locations, &r.meshes, &r.shadow_instances, &r.shadow_elements, &r.vis};
  const GpuShadowRasterBuffers buffers{{g, &r.counters}, &r.shadow_pages, &r.shadow_element_page, &r.shadow_pool};
  // Bound but not read by the shadow variant: the visibility buffer and the path words (a
  // renderer that drew no primary view yet has neither).
  ensure_size(*r.gpu, r.vis, sizeof(uint64_t));
  ensure_size(*r.gpu, r.raster->paths, sizeof(uint32_t));
  begin_commands(rec);
  cmd_fill(rec, r.counters, 0);
  if (hardware) {
    record_gpu_shadow_hw_raster(rec, *r.raster, buffers, r.shadow_table, elements.pages, elements.hw_draws);
    submit_and_wait(rec);
    return;
  }
  record_gpu_shadow_raster(rec, *r.raster, buffers, element_count);
  continue_commands(rec);  // the host cuts the deferred big triangles into tiles (spec/raster.md §13.5)
  RasterSplitStats tiled;
  record_gpu_shadow_raster_tiles(rec, *r.raster, buffers, element_count, &tiled);
  submit_and_wait(rec);
  const uint32_t overflow = r.counters.data<uint32_t>()[kGpuRasterOverflowWord];
  if (overflow != 0)  // never a silently wrong page (raster_range's guard)
    fail("GPU_SCENE_TOO_LARGE", r.gpu->device_name,
         std::to_string(overflow) + " shadow-page triangle(s) needed more pixel-loop iterations than the compute "
             "rasterizer's loop budget (spec/raster.md §13.5)",
         kExitUsage);
}

// The lit view's lights and shadow maps (spec/shadow.md §2, §6) for shade.comp: `shadows` the
// frame's maps when shadow_draw ran (r.shadow_pool then holds the pool), else null (every
// shadow term 1, as shade.cpp without ShadeInput::shadows).
void upload_lit_frame(GpuRenderer& r, const RenderScene& scene, const RenderSettings& settings, const Frame& out,
                      const ShadowFrame* shadows) {
  GpuContext& gpu = *r.gpu;
  GpuLitFrame frame{};
  put_rows(rigid_inverse(out.view.world_to_view), frame.view_to_world, 3);
  put_rows(out.view.world_to_view, frame.world_to_view, 3);
  frame.z_near = out.view.z_near;
  frame.light_count = settings.view == ShadeView::kLit ? uint32_t(scene.lights.size()) : 0u;
  const ShadowOptions options = shadows ? shadows->options : ShadowOptions{};
  frame.tau = double(options.threshold_px);  // shadow_term's τ, τ_s
  frame.tau_s = double(kShadowLodBias) * frame.tau;
  frame.max_slope = kMaxShadowSlope;
  frame.max_mismatch_secant = kMaxMismatchSecant;
  frame.texels_per_pixel_log2 = options.texels_per_pixel_log2;
  frame.pages_per_side = options.pages_per_side;
  uint32_t mips = 1;
  while (mips < kShadowMips && (options.pages_per_side >> mips) > 0) ++mips;  // virtual_shadow.cpp mip_count
  frame.mips = mips;
  frame.directional_levels = kDirectionalLevels;
  frame.trace_max_steps = kShadowTraceMaxSteps;
  std::vector<GpuShadeLight> lights(std::max<size_t>(scene.lights.size(), 1));
  for (size_t i = 0; i < scene.lights.size(); ++i) {
    const Light& l = scene.lights[i];
    GpuShadeLight& g = lights[i];
    g = {};
    g.position[0] = l.position.x, g.position[1] = l.position.y, g.position[2] = l.position.z;
    g.direction[0] = l.direction.x, g.direction[1] = l.direction.y, g.direction[2] = l.direction.z;
    g.cos_half_cone = std::cos(0.5 * l.cone_radians);
    std::copy(l.color.begin(), l.color.end(), g.color);
    g.intensity = l.intensity;
    g.type = uint32_t(l.type);
    const bool has_maps = shadows && i < shadows->light_first_map.size() && shadows->light_first_map[i] != kNoShadowSlot;
    g.shadows = l.shadows && has_maps ? 1u : 0u;
    g.first_map = has_maps ? shadows->light_first_map[i] : 0u;
    g.map_count = has_maps ? shadows->light_map_count[i] : 0u;
  }
  const std::vector<uint32_t> no_table{kNoShadowSlot};
  const std::vector<uint32_t>& table = shadows && !shadows->page_table.empty() ? shadows->page_table : no_table;
  auto put = [&](GpuBuffer& b, const void* data, uint64_t bytes) {
    check_buffer_range(gpu, bytes, "the lit view's lights and shadow maps");
    ensure_size(gpu, b, bytes);
    std::memcpy(b.mapped, data, bytes);
  };
  put(r.lit_frame, &frame, sizeof frame);
  put(r.shade_lights, lights.data(), lights.size() * sizeof(GpuShadeLight));
  upload_shadow_maps(r, shadows);
  put(r.shadow_table, table.data(), table.size() * sizeof(uint32_t));
  if (!shadows) ensure_size(gpu, r.shadow_pool, sizeof(float));  // bound, never read
}

// Step shadow_mark on the device (shadow_mark.comp, spec/shadow.md §4): out->shadow (made by
// begin_shadow_mark) gets the needed pages of the covered pixels of r.vis.
void shadow_mark_pass(GpuRenderer& r, const RenderScene& scene, const RenderSettings& settings, Frame* out) {
  GpuContext& gpu = *r.gpu;
  ShadowFrame& frame = out->shadow;
  upload_lit_frame(r, scene, settings, *out, &frame);
  const uint64_t bytes = std::max<uint64_t>(frame.needed.size(), 1) * sizeof(uint32_t);
  check_buffer_range(gpu, bytes, "the shadow page marks");
  ensure_size(gpu, r.shadow_needed, bytes);
  std::memset(r.shadow_needed.mapped, 0, bytes);
  GpuShadeParams params{};
  params.tan_half_x = out->view.tan_half_x;
  params.tan_half_y = out->view.tan_half_y;
  params.width = out->view.width;
  params.height = out->view.height;
  const uint64_t pixels = uint64_t(params.width) * params.height;
  GpuRecorder& rec = *r.recorder;
  begin_commands(rec);
  cmd_dispatch(rec, r.shadow_mark,
               gpu_bindings(kMarkBindingCount, {{kMarkBindVis, &r.vis},
                                                {kMarkBindLitFrame, &r.lit_frame},
                                                {kMarkBindLights, &r.shade_lights},
                                                {kMarkBindShadowMaps, &r.shadow_maps},
                                                {kMarkBindNeeded, &r.shadow_needed}}),
               &params, uint32_t((pixels + kShadeGroupSize - 1) / kShadeGroupSize));
  submit_and_wait(rec);
  const uint32_t* marks = r.shadow_needed.data<uint32_t>();
  for (size_t e = 0; e < frame.needed.size(); ++e) frame.needed[e] = uint8_t(marks[e] != 0);
  for (uint8_t n : frame.needed) frame.pages_marked += n;  // as mark_shadow_pages counts
}

// shade.cpp shade_frame on the GPU: every view, from the visibility buffer now in r.vis.
void shade_pass(GpuRenderer& r, const RenderScene& scene, const RenderSettings& settings, const Camera& camera,
                const ShadowFrame* shadows, Frame* out) {
  GpuContext& gpu = *r.gpu;
  upload_lit_frame(r, scene, settings, *out, shadows);
  const ShadeInput defaults;
  std::vector<GpuShadeInstance> si(scene.instances.size());
  for (size_t i = 0; i < si.size(); ++i) {
    std::copy(std::begin(out->instance_views[i].object_to_view.m), std::end(out->instance_views[i].object_to_view.m),
              si[i].object_to_view);
    double nm[3][3];
    shade_normal_matrix(scene.instances[i].object_to_world, nm);
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) si[i].normal_matrix[3 * row + col] = nm[row][col];
  }
  LodView lv;
  lv.pixels_per_unit_at_1 = out->view.pixels_per_unit_at_1;
  lv.z_near = float(out->view.z_near);
  std::vector<GpuShadeCluster> sc(out->visible.size());
  for (size_t i = 0; i < sc.size(); ++i) {
    const VisibleCluster& v = out->visible[i];
    const ClusterDag& dag = scene.meshes[scene.instances[v.instance].mesh];
    const DagCluster& c = dag.clusters[v.cluster];
    const InstanceView& iv = out->instance_views[v.instance];
    sc[i] = {c.group, c.level, dag.level_count,
             projected_error(sphere_to_view(iv.object_to_view, iv.scale, c.lod_bounds), error_to_view(c.lod_error, iv.scale), lv)};
  }
  const uint64_t pixels = uint64_t(camera.width) * camera.height;
  ensure_size(gpu, r.shade_instances, si.size() * sizeof(GpuShadeInstance));
  if (!si.empty()) std::memcpy(r.shade_instances.mapped, si.data(), si.size() * sizeof(GpuShadeInstance));
  ensure_size(gpu, r.shade_clusters, sc.size() * sizeof(GpuShadeCluster));
  if (!sc.empty()) std::memcpy(r.shade_clusters.mapped, sc.data(), sc.size() * sizeof(GpuShadeCluster));
  uint32_t max_overdraw = 1;
  const bool overdraw = settings.view == ShadeView::kOverdraw && !out->overdraw.empty();
  ensure_size(gpu, r.overdraw, overdraw ? pixels * 4 : 4);
  if (overdraw) {
    std::memcpy(r.overdraw.mapped, out->overdraw.data(), pixels * 4);
    for (uint32_t c : out->overdraw) max_overdraw = std::max(max_overdraw, c);
  }
  ensure_size(gpu, r.image, pixels * 4);

  GpuShadeParams params{};
  params.tan_half_x = out->view.tan_half_x;
  params.tan_half_y = out->view.tan_half_y;
  const Vec3 L = defaults.light_direction;
  const double ll = std::sqrt(double(L.x) * L.x + double(L.y) * L.y + double(L.z) * L.z);
  params.light[0] = L.x / ll;
  params.light[1] = L.y / ll;
  params.light[2] = L.z / ll;
  params.width = camera.width;
  params.height = camera.height;
  params.view = uint32_t(settings.view);
  params.material_count = uint32_t(scene.materials.size());
  params.ambient = defaults.ambient;
  params.threshold_px = settings.threshold_px;
  params.max_overdraw = max_overdraw;
  GpuRecorder& rec = *r.recorder;
  begin_commands(rec);
  std::vector<GpuBinding> bindings = geometry_bindings(geometry(r));
  bindings.insert(bindings.end(), {{kShadeBindInstances, &r.shade_instances},
                                   {kShadeBindClusters, &r.shade_clusters},
                                   {kShadeBindMaterials, &r.materials},
                                   {kShadeBindOverdraw, &r.overdraw},
                                   {kShadeBindImage, &r.image},
                                   {kShadeBindLitFrame, &r.lit_frame},
                                   {kShadeBindLights, &r.shade_lights},
                                   {kShadeBindShadowMaps, &r.shadow_maps},
                                   {kShadeBindShadowTable, &r.shadow_table},
                                   {kShadeBindShadowPool, &r.shadow_pool}});
  cmd_dispatch(rec, r.shade, gpu_bindings(kShadeBindingCount, bindings), &params, uint32_t((pixels + kShadeGroupSize - 1) / kShadeGroupSize));
  submit_and_wait(rec);

  out->image.width = camera.width;
  out->image.height = camera.height;
  out->image.rgb.resize(pixels * 3);
  const uint32_t* rgba = r.image.data<uint32_t>();
  for (uint64_t p = 0; p < pixels; ++p)
    for (int k = 0; k < 3; ++k) out->image.rgb[3 * p + k] = uint8_t(rgba[p] >> (8 * k));
}

// Every listed cluster of a streamed mesh has its page in the GPU pool (the raster reads
// installed pages only; meshes not streamed have all their pages placed after the pool).
void check_clusters_in_pool(const GpuRenderer& r, const RenderScene& scene, const FrameStreaming& s,
                            const std::vector<VisibleCluster>& clusters) {
  const FormatContainer& c = s.streamer->container();
  for (const VisibleCluster& v : clusters) {
    const uint32_t m = scene.instances[v.instance].mesh;
    if (s.stream_mesh[m] == kNone) continue;
    const uint32_t page = c.meshes[s.stream_mesh[m]].cluster_page[v.cluster];
    if (r.slot_of_page[page] == kNone)
      fail("GPU_ERROR", "vulkan", "drawn cluster " + std::to_string(v.cluster) + " of a page not in the GPU pool",
           kExitInternal);
  }
}

}  // namespace

bool shadow_pages_use_hardware_raster(GpuRasterMode mode) { return mode == GpuRasterMode::kHw; }

void draw_shadow_pages_vulkan(GpuRenderer& r, const RenderScene& scene, ThreadPool& /*pool*/, ShadowFrame* frame,
                              ShadowCache* cache, GpuRasterMode mode, FrameStreaming* streaming) {
  ShadowCache local;
  ShadowCache* c = cache ? cache : &local;
  // Streaming (spec/shadow.md §9), as frame.cpp's shadow_draw: the views draw the resident cut of
  // what stream_end left resident (a subset of the pages sync_page_pool placed at stream_begin,
  // since reads complete only at a frame's start), and their requests go to the next stream_end.
  if (streaming) refresh_usable_groups(scene, streaming);
  // Cache and allocation on the host (the reference's code: per page, a few thousand at most),
  // the multi-view cull on the device (spec/shadow.md §8).
  ShadowDrawPlan plan = plan_shadow_draw(scene.meshes, scene.instances, scene.lights, frame, c);
  GpuShadowCull cull = cull_shadow_views_vulkan(r, scene, *frame, plan, streaming ? &streaming->usable : nullptr);
  ShadowDrawList built = std::move(cull.list);
  finish_shadow_cull(scene.instances, std::move(plan), frame, c, &built);
  if (streaming) {
    check_clusters_in_pool(r, scene, *streaming, shadow_draw_clusters(built));
    streaming->shadow_requests = std::move(built.requests);
  }
  auto drawn = std::make_shared<const ShadowDrawList>(std::move(built));
  const ShadowDrawList& list = *drawn;
  GpuContext& gpu = *r.gpu;
  const uint64_t pool_bytes = c->texels.size() * sizeof(float);
  check_buffer_range(gpu, pool_bytes, "the shadow page pool");
  ensure_size(gpu, r.shadow_pool, std::max<uint64_t>(pool_bytes, 4));
  if (pool_bytes) std::memcpy(r.shadow_pool.mapped, c->texels.data(), pool_bytes);
  float* device_pool = r.shadow_pool.data<float>();
  for (const ShadowPageDraw& p : list.pages)
    std::memset(device_pool + p.slot * kShadowPageTexelCount, 0, kShadowPageTexelCount * sizeof(float));
  if (!list.pages.empty())
    raster_shadow_pages(r, upload_shadow_raster_inputs(r, scene, *frame, list, cull), shadow_pages_use_hardware_raster(mode));
  for (const ShadowPageDraw& p : list.pages)
    std::memcpy(c->texels.data() + p.slot * kShadowPageTexelCount, device_pool + p.slot * kShadowPageTexelCount,
                kShadowPageTexelCount * sizeof(float));
  end_shadow_draw(scene.instances, scene.lights, frame, c, cache != nullptr);
  frame->drawn = std::move(drawn);
}

namespace {

// The Vulkan executor of the frame plan (frame_plan.h): every step on the device, each
// submitted and waited for on its own, so execute_frame_plan's per-step wall time is the
// device's time per pass (plus the host's small uploads and readbacks). The visible lists
// are read back after each cull pass (Frame::visible, and the raster's input buffer); the
// HZB of a kept history is read back into FrameHistory and uploaded again as the next
// frame's previous HZB (lavapipe's memory is host memory: both are copies, no cull).
// Overdraw (only for the overdraw view) is counted on the host, as frame.cpp does.
class VulkanFrameExecutor final : public FrameExecutor {
 public:
  VulkanFrameExecutor(GpuRenderer& r, const FramePlan& plan, const FrameInputs& in, Frame* out,
                      RasterSplitStats* split)
      : r_(r), in_(in), out_(out), split_(split) {
    const RenderScene& scene = in.scene;
    const Camera& camera = in.camera;
    const RenderSettings& settings = in.settings;
    FrameHistory* history = in.history;
    GpuContext& gpu = *r.gpu;
    // Lights and shadows (spec/shadow.md) run here as on the CPU: the shadow test's double
    // arithmetic needs shaderFloat64, which create_gpu_context requires of every device (the
    // raster's arithmetic needs it too), so no lit scene is refused.
    object_to_clip_ = begin_frame(scene, camera, out);  // the CPU executor's matrices, bit for bit
    std::vector<GpuInstance> instances(scene.instances.size());
    for (size_t i = 0; i < instances.size(); ++i) {
      std::memcpy(instances[i].object_to_clip, object_to_clip_[i].m, sizeof(instances[i].object_to_clip));
      instances[i].mesh = scene.instances[i].mesh;
    }
    ensure_size(gpu, r.instances, instances.size() * sizeof(GpuInstance));
    if (!instances.empty()) std::memcpy(r.instances.mapped, instances.data(), instances.size() * sizeof(GpuInstance));
    const uint64_t vis_bytes = uint64_t(camera.width) * camera.height * 8;
    check_buffer_range(gpu, vis_bytes, "the visibility buffer");
    ensure_size(gpu, r.vis, vis_bytes);
    std::memset(r.vis.mapped, 0, vis_bytes);

    if (!r.cull_frame || r.cull_frame->hzb_layout.width != camera.width ||
        r.cull_frame->hzb_layout.height != camera.height)
      r.cull_frame = std::make_unique<GpuCullFrame>(
          create_cull_frame(gpu, scene.meshes, scene.instances, camera.width, camera.height));
    GpuCullFrame& f = *r.cull_frame;
    write_cull_instances(f, scene.instances, out->instance_views, false);
    const GpuOcclusion previous{&history_view(), true, settings.hzb_policy};
    if (plan.previous_hzb) {
      write_cull_instances(f, scene.instances, history->instance_views, true);
      write_previous_hzb(f, history->hzb);
    }
    const CullOptions defaults;
    write_cull_params(f, 0, out->view, settings.threshold_px, defaults.frustum, plan.previous_hzb ? &previous : nullptr);
    const GpuOcclusion current{&out->view, false, settings.hzb_policy};
    write_cull_params(f, 1, out->view, settings.threshold_px, defaults.frustum, &current);
  }

  StepResult run(FrameStep step, const FrameState& state, PassStats* p) override {
    GpuRecorder& rec = *r_.recorder;
    GpuCullFrame& f = *r_.cull_frame;
    const GpuCullPipelines& cp = r_.cull;
    GpuCullMeshes& m = r_.cull_meshes;
    StepResult r;
    switch (step) {
      case FrameStep::kStreamBegin:
        // The Streamer installs completed reads; the pool mirrors its residency; the cull
        // passes get the usable masks (the same ones the CPU executor's traversal reads).
        begin_streamed_frame(in_.scene, in_.streaming);
        sync_page_pool(r_, *in_.streaming);
        write_cull_usable(m, in_.streaming->usable);
        break;
      case FrameStep::kStreamBind:
        check_bound(0);
        break;
      case FrameStep::kStreamBindPost:
        check_bound(out_->pass1_visible);
        break;
      case FrameStep::kStreamEnd:
        end_streamed_frame(in_.streaming, state.requests, state.clusters_coarser, out_->visible.size());
        break;
      case FrameStep::kInstanceCull: {
        begin_commands(rec);
        cmd_cull_instances(rec, cp, m, f, 0, f.candidates, f.visible_instances, &f.occluded_instances, f.counters[0]);
        submit_and_wait(rec);
        add_instance_counters(read_cull_counters(f.counters[0]), p);
        r.occluded = list_count(f.occluded_instances) != 0;
        break;
      }
      case FrameStep::kClusterCull: {
        begin_commands(rec);
        cmd_cull_clusters(rec, cp, m, f, 0, r_.traversal, f.visible_instances, nullptr, f.visible[0], false,
                          &f.occluded_items, f.counters[1]);
        submit_and_wait(rec);
        const CullCounters cc = read_cull_counters(f.counters[1]);
        add_cull_counters(cc, p);
        r.requests = take_cull_requests(m);
        r.clusters_coarser = cc.clusters_coarser;
        r.visible = read_visible_list(f.visible[0]);
        r.occluded = list_count(f.occluded_items) != 0;
        break;
      }
      case FrameStep::kRaster:
        raster(0, p);
        break;
      case FrameStep::kHzb:
        begin_commands(rec);
        cmd_build_hzb(rec, cp, f, r_.vis, f.hzb);
        submit_and_wait(rec);
        break;
      case FrameStep::kInstanceCullPost:
        begin_commands(rec);
        cmd_cull_instances(rec, cp, m, f, 1, f.occluded_instances, f.post_instances, nullptr, f.counters[2]);
        submit_and_wait(rec);
        add_instance_counters(read_cull_counters(f.counters[2]), p);
        break;
      case FrameStep::kClusterCullPost: {
        begin_commands(rec);
        cmd_cull_clusters(rec, cp, m, f, 1, r_.traversal, f.post_instances, &f.occluded_items, f.visible[1], false,
                          nullptr, f.counters[3]);
        submit_and_wait(rec);
        const CullCounters cc = read_cull_counters(f.counters[3]);
        add_cull_counters(cc, p);
        r.requests = take_cull_requests(m);
        r.clusters_coarser = cc.clusters_coarser;
        r.visible = read_visible_list(f.visible[1]);
        break;
      }
      case FrameStep::kRasterPost:
        raster(out_->pass1_visible, p);
        break;
      case FrameStep::kHzbNext:
        if (!state.hzb_is_complete) {
          begin_commands(rec);
          cmd_build_hzb(rec, cp, f, r_.vis, f.hzb);
          submit_and_wait(rec);
        }
        in_.history->hzb = read_hzb(f, f.hzb);
        break;
      case FrameStep::kOverdraw:
        // On the host, as frame.cpp; a streamed frame's geometry is decoded from its pages here.
        if (in_.streaming) bind_streamed_geometry(in_.streaming, in_.scene, out_->visible, 0, in_.pool);
        overdraw_pass(in_.scene, in_.streaming ? in_.streaming->geometry : in_.scene.meshes, out_->visible, object_to_clip_,
                      out_->instance_views, out_->view, in_.pool, &out_->overdraw);
        break;
      case FrameStep::kShade:
        shade_pass(r_, in_.scene, in_.settings, in_.camera, shadows_drawn_ ? &out_->shadow : nullptr, out_);
        break;
      case FrameStep::kShadowMark:
        // The maps on the host (a few matrices per light), the marks on the device from its
        // visibility buffer (shadow_mark.comp: the reference's texel selection in its
        // arithmetic); the needed set is read back for the allocation and the cull.
        begin_shadow_mark(in_, out_);
        shadow_mark_pass(r_, in_.scene, in_.settings, out_);
        shadows_drawn_ = true;
        break;
      case FrameStep::kShadowDraw:
        draw_shadow_pages_vulkan(r_, in_.scene, in_.pool, &out_->shadow,
                                 in_.history ? &in_.history->shadow_cache : nullptr, r_.options.raster,
                                 in_.streaming);
        r.shadow = shadow_frame_stats(out_->shadow);
        break;
    }
    return r;
  }

  void finish() override {
    std::memcpy(out_->vis.keys.data(), r_.vis.mapped, out_->vis.keys.size() * sizeof(uint64_t));
  }

 private:
  // Every streamed visible[first..] cluster's page is in the GPU pool (it is resident: its
  // group is usable), so the raster and shade passes read installed pages only. (Meshes not
  // streamed have all their pages placed after the pool.)
  void check_bound(uint32_t first) const {
    check_clusters_in_pool(r_, in_.scene, *in_.streaming,
                           std::vector<VisibleCluster>(out_->visible.begin() + first, out_->visible.end()));
  }
  const ViewParams& history_view() const {
    static const ViewParams none;
    return in_.history ? in_.history->view : none;
  }
  static uint32_t list_count(const GpuBuffer& list) { return list.data<uint32_t>()[0]; }
  // Rasterizes visible[first, n) (frame.cpp raster_pass's counters; the time is the step's).
  void raster(uint32_t first, PassStats* p) {
    static_assert(sizeof(VisibleCluster) == sizeof(GpuVisibleCluster));
    const std::vector<VisibleCluster>& visible = out_->visible;
    const uint32_t n = uint32_t(visible.size());
    ensure_size(*r_.gpu, r_.visible, visible.size() * sizeof(GpuVisibleCluster));
    if (!visible.empty()) std::memcpy(r_.visible.mapped, visible.data(), visible.size() * sizeof(GpuVisibleCluster));
    std::vector<float> scale(in_.scene.instances.size());
    for (size_t i = 0; i < scale.size(); ++i) scale[i] = float(out_->instance_views[i].scale);
    prepare_gpu_raster(*r_.raster, scale, n);
    PassStats gpu;
    // frame.cpp raster_pass: RasterOptions::z_near = float(z_near), default back-face culling.
    raster_range(r_, in_.camera.width, in_.camera.height, float(in_.camera.z_near), out_->view.pixels_per_unit_at_1,
                 RasterOptions{}.cull_backfaces, first, n - first, &gpu, split_);
    p->pixels_written += gpu.pixels_written;  // clusters and triangles drawn: execute_frame_plan
  }

  GpuRenderer& r_;
  bool shadows_drawn_ = false;  // shadow_mark ran: the shade pass applies the shadow terms
  const FrameInputs& in_;
  Frame* out_;
  RasterSplitStats* split_;  // clusters and triangles per raster path, summed over the passes
  std::vector<Mat4> object_to_clip_;
};

}  // namespace

void render_frame_vulkan(GpuRenderer& r, const FrameInputs& in, Frame* out) {
  if ((in.streaming != nullptr) != r.streamed)
    fail("GPU_ERROR", "vulkan", "a streamed frame needs a streamed renderer and only it", kExitInternal);
  RasterSplitStats frame_split;
  const FramePlan plan = plan_frame(in.scene, in.settings, frame_context(in));
  const auto frame_start = std::chrono::steady_clock::now();
  VulkanFrameExecutor executor(r, plan, in, out, &frame_split);
  execute_frame_plan(plan, executor, in.scene, in.history, in.streaming, out);
  out->stats.total_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - frame_start).count();
  out->stats.has_raster_split = true;
  out->stats.raster_split = frame_split;
}

void raster_visible_vulkan(GpuRenderer& r, const GpuRasterInput& in, GpuRasterOutput* out) {
  upload_raster_inputs(r, in.object_to_clip, in.instance_mesh, in.instance_scale, in.visible, in.width, in.height);
  PassStats pass;
  out->split = {};
  raster_range(r, in.width, in.height, in.z_near, in.pixels_per_unit_at_1, in.cull_backfaces, 0,
               uint32_t(in.visible.size()), &pass, &out->split);
  out->ms = pass.ms;
  out->pixels_written = pass.pixels_written;
  out->vis.width = in.width;
  out->vis.height = in.height;
  out->vis.keys.resize(size_t(in.width) * in.height);
  std::memcpy(out->vis.keys.data(), r.vis.mapped, out->vis.keys.size() * 8);
}

}  // namespace vgeo
