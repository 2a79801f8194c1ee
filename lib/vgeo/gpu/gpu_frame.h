#pragma once
// The Vulkan frame executor (spec/gpu.md §Frame): executes the same FramePlan as the CPU
// reference (lib/vgeo/render/frame_plan.h), with the same pass names, PassStats and Frame
// result. Every pass runs on the device: instance cull, hierarchical LOD + cluster cull
// (gpu_cull.h, persistent or level-by-level traversal), raster (compute, 64-bit
// atomicMax), HZB, pass 2, shade, reading the memory-form pages as they are (the scene's own
// encodings, transcoded: MemoryFormPages). Only the
// overdraw view's per-pixel counts are computed on the host.
#include <cstdint>
#include <memory>
#include <vector>

#include "vgeo/format/format.h"
#include "vgeo/gpu/context.h"
#include "vgeo/gpu/gpu_cull.h"
#include "vgeo/gpu/hw_raster.h"
#include "vgeo/gpu/memory_form.h"
#include "vgeo/render/frame.h"
#include "vgeo/render/run.h"  // GpuPoolStats
#include "vgeo/render/scene_file.h"
#include "vgeo/render/streaming.h"

namespace vgeo {

struct GpuRenderer;  // pipelines and per-scene GPU buffers (gpu_renderer.h)
struct GpuRendererDeleter {
  void operator()(GpuRenderer* r) const;
};
using GpuRendererPtr = std::unique_ptr<GpuRenderer, GpuRendererDeleter>;

struct GpuRendererOptions {
  GpuRasterMode raster = GpuRasterMode::kSw;  // which GPU rasterizer draws each cluster (hw_raster.h)
  float hw_min_triangle_area_px = kAutoHwMinTriangleAreaPx;  // the auto rule's threshold
};

// Uploads the pages once. Throws GPU_SCENE_TOO_LARGE when the pages exceed one storage
// buffer (maxStorageBufferRange), GPU_ERROR when `pages` is not the memory form of every
// mesh of `scene`.
GpuRendererPtr create_gpu_renderer(GpuContext& gpu, const RenderScene& scene, const MemoryFormPages& pages,
                                   GpuTraversal traversal = kDefaultGpuTraversal,
                                   const GpuRendererOptions& options = {});
GpuRendererPtr create_gpu_renderer(GpuContext& gpu, const MemoryFormScene& scene,
                                   GpuTraversal traversal = kDefaultGpuTraversal,
                                   const GpuRendererOptions& options = {});
// The renderer's page buffer as uploaded (tests: the GPU reads exactly the scene's memory form).
std::vector<uint32_t> gpu_page_words(const GpuRenderer& renderer);

// Per (mesh, cluster) in location order: the bounds and triangle count the split rule reads.
std::vector<GpuClusterRasterInfo> cluster_raster_infos(const RenderScene& scene);

// The raster passes alone (raster vectors, `vgeo bench raster`): `visible` clusters of the
// scene's instances, drawn with per-instance float object→clip matrices (as frame.cpp makes
// them) into a cleared width × height visibility buffer, by the renderer's raster mode.
struct GpuRasterInput {
  std::vector<Mat4> object_to_clip;   // per instance
  std::vector<uint32_t> instance_mesh;  // per instance
  std::vector<float> instance_scale;  // per instance (InstanceView::scale)
  std::vector<VisibleCluster> visible;
  uint32_t width = 0, height = 0;
  float z_near = 0.01f;
  float pixels_per_unit_at_1 = 1;
  bool cull_backfaces = true;
};
struct GpuRasterOutput {
  VisBuffer vis;
  RasterSplitStats split;
  double ms = 0;                // GPU time of the raster passes
  uint64_t pixels_written = 0;  // covered pixel centres of both paths (write attempts)
};
void raster_visible_vulkan(GpuRenderer& renderer, const GpuRasterInput& input, GpuRasterOutput* out);

// Streaming (spec/gpu.md §Streaming): the renderer of a streamed scene (`scene`: its
// metadata-only meshes, as init_frame_streaming leaves them). The page buffer is a fixed pool
// of slots, each the size of the largest memory-form page, as many as the budget can hold
// pages at once; pages are uploaded when the Streamer installs them and their slots freed when
// it evicts them. Meshes not streamed (not from a page file) are drawn from `in_memory`'s
// pages (memory_form_pages of the scene), uploaded once after the pool.
GpuRendererPtr create_gpu_renderer_streamed(GpuContext& gpu, const RenderScene& scene, const FrameStreaming& streaming,
                                            const MemoryFormPages& in_memory,
                                            GpuTraversal traversal = kDefaultGpuTraversal,
                                            const GpuRendererOptions& options = {});
const GpuPoolStats& gpu_pool_stats(const GpuRenderer& renderer);

// Step shadow_draw on the device (spec/shadow.md §5): the CPU reference's cache invalidation and
// allocation (plan_shadow_draw), the multi-view cull on the device (cull_shadow_views_vulkan),
// then every page to draw rasterized by the compute
// rasterizer scissored to the page (one element per cluster and overlapped page) into the
// device's pool, bit-identical to draw_shadow_pages. The pool is uploaded from cache->texels
// first (the history is the truth, as for the HZB) and the drawn slots are read back into it,
// so frame->pool_texels reads what the device holds. `cache` null: nothing is kept (as the CPU).
// `mode`: with shadow_pages_use_hardware_raster(mode) the pages are drawn by the hardware raster
// instead (through the page table, spec/shadow.md §8: equal to the CPU's within the shadow-page
// hardware rule, shadow_hw_rule.h, not bitwise). `streaming` (a streamed frame, after
// stream_end): the views draw the resident cut and leave their requests in
// streaming->shadow_requests, as the CPU executor (spec/shadow.md §9).
void draw_shadow_pages_vulkan(GpuRenderer& renderer, const RenderScene& scene, ThreadPool& pool, ShadowFrame* frame,
                              ShadowCache* cache, GpuRasterMode mode = GpuRasterMode::kSw,
                              FrameStreaming* streaming = nullptr);
// The shadow views' multi-view cull on the device (shaders/shadow_cull.comp, spec/shadow.md §8):
// the instance cull, then per kept (view, instance) every cluster's LOD test from the view's own
// projection and texel rectangle against the view's pages to draw, in the reference's
// arithmetic. Its elements stay on the device as the shadow raster's inputs
// (GpuRenderer::shadow_elements, shadow_element_page; element order is the device's) and are
// read back into `list`: per page its clusters in (instance, cluster) order, the provisional
// pages, and the requests as one per (mesh, group) with the highest priority, ascending (the
// Streamer's reduction of cull_shadow_views' list). `usable` non-null: a streamed frame (the
// resident cut; spec/shadow.md §9), as cull_shadow_views.
struct GpuShadowCull {
  ShadowDrawList list;                  // clusters, provisional, requests (pages and matrices: finish_shadow_cull)
  std::vector<GpuVisibleCluster> elements;  // as the device wrote them (instance: the pair view · n + instance)
  std::vector<uint32_t> element_page;       // each element's page (index into the plan's pages)
  uint64_t pairs_kept = 0;              // (view, instance) pairs the instance cull kept
  double ms = 0;                        // device time of the cull's dispatches
};
GpuShadowCull cull_shadow_views_vulkan(GpuRenderer& renderer, const RenderScene& scene, const ShadowFrame& frame,
                                       const ShadowDrawPlan& plan, const std::vector<std::vector<uint8_t>>* usable);
// Which path draws the shadow pages under a frame's raster mode (spec/shadow.md §8): the
// hardware raster under `hw`; the compute raster under `sw` and `auto`.
bool shadow_pages_use_hardware_raster(GpuRasterMode mode);

// Renders one frame of in.scene, a scene the renderer was made for (as render_frame:
// plan_frame, then the Vulkan executor); FrameStats::raster_split counts the frame's clusters
// and triangles per raster path. in.streaming is non-null exactly for a streamed renderer: the
// traversal reads its usable masks and writes its requests into a buffer read back after each
// cull pass, handed to its Streamer at stream_end (as the CPU).
void render_frame_vulkan(GpuRenderer& renderer, const FrameInputs& in, Frame* out);

}  // namespace vgeo
