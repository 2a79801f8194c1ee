#pragma once
// The GPU raster passes (spec/raster.md §13): the compute software rasterizer
// (shaders/raster.comp, bit-identical to the CPU), the hardware raster pipeline (a graphics
// pipeline with no attachments, dynamic rendering: shaders/hw_raster.vert decodes the
// cluster's memory form, shaders/hw_raster.frag does the same 64-bit atomicMax), and the
// per-cluster split between them (shaders/raster_split.comp). Both write one visibility
// buffer with the key of core/vis_key.h.
//
// Input interface: the visible-cluster buffer (GpuVisibleCluster per visible index) and a
// range [first, first + count) of it. The split pass reads it on the GPU and writes the draw
// commands and their count for vkCmdDrawIndirectCount, so whoever fills the visible buffer
// (today the host cull, later the GPU cull) feeds the hardware path with no CPU round trip.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vgeo/gpu/context.h"
#include "vgeo/gpu/hw_raster_records.h"
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shader_records.h"  // GpuShadowPage
#include "vgeo/render/frame_plan.h"  // RasterSplitStats

namespace vgeo {

// `vgeo render --raster sw|hw|auto`: which GPU rasterizer draws each visible cluster.
enum class GpuRasterMode : uint8_t {
  kSw = 0,    // every cluster by the compute rasterizer (bit-identical to the CPU reference)
  kHw = 1,    // every cluster by the hardware pipeline
  kAuto = 2,  // per cluster by the rule of spec/raster.md §13.2
};
bool parse_gpu_raster_mode(const std::string& name, GpuRasterMode* out);
const char* gpu_raster_mode_name(GpuRasterMode mode);

// The auto rule's threshold: a cluster whose estimated projected triangle area
// (π r_px² / triangles, spec/raster.md §13.2) is at least this goes to the hardware path.
// Where `vgeo bench raster`'s compute-SW and hardware curves cross on lavapipe: SW/HW 1.01×
// at 8-px legs (32 px²), 0.83× at 16 px (128 px²); 64 px² is the geometric middle
// (docs/bench/report.md §raster; on lavapipe the sides are inverted, see spec §13.4).
inline constexpr float kAutoHwMinTriangleAreaPx = 64.0f;


// Pipelines of the three passes and the buffers only they use. Move-only; frees itself.
struct GpuRasterPasses {
  GpuContext* context = nullptr;
  ComputePipeline sw, sw_tiles, split;  // raster.comp, raster_tiles.comp, raster_split.comp
  ComputePipeline shadow, shadow_tiles;  // raster_shadow.comp, raster_shadow_tiles.comp
  VkDescriptorSetLayout hw_set_layout = VK_NULL_HANDLE;
  VkPipelineLayout hw_layout = VK_NULL_HANDLE;
  VkPipeline hw = VK_NULL_HANDLE;
  // The shadow pages' hardware raster (hw_shadow.vert/.frag, kHwShadowBindingCount bindings).
  VkDescriptorSetLayout hw_shadow_set_layout = VK_NULL_HANDLE;
  VkPipelineLayout hw_shadow_layout = VK_NULL_HANDLE;
  VkPipeline hw_shadow = VK_NULL_HANDLE;
  GpuBuffer cluster_info;      // GpuClusterRasterInfo per (mesh, cluster), GpuClusterLocation order
  GpuBuffer raster_instances;  // GpuRasterInstance per instance (per frame)
  GpuBuffer paths;             // kGpuRasterPath* per visible cluster (per frame)
  GpuBuffer commands;          // GpuDrawCommand per hardware cluster (per frame)
  GpuBuffer split_counters;    // GpuRasterSplitCounters
  GpuBuffer big_triangles;     // GpuBigTriangle per deferred triangle (kGpuRasterMaxBigTriangles)
  GpuBuffer tiles;             // GpuRasterTile per tile of a tile-pass dispatch (grown on demand)

  GpuRasterPasses() = default;
  GpuRasterPasses(const GpuRasterPasses&) = delete;
  GpuRasterPasses& operator=(const GpuRasterPasses&) = delete;
  ~GpuRasterPasses();
};

// `cluster_info`: one record per (mesh, cluster) in the order of the location buffer.
std::unique_ptr<GpuRasterPasses> create_gpu_raster_passes(GpuContext& gpu,
                                                          const std::vector<GpuClusterRasterInfo>& cluster_info);

// Per frame, before recording: the instances' scale factors and the visible-cluster count
// (sizes the path and command buffers).
void prepare_gpu_raster(GpuRasterPasses& passes, const std::vector<float>& instance_scale, uint32_t visible_total);

// The geometry every raster and shade shader reads (shaders/geometry.glsl) and the visibility
// buffer, owned by the caller; geometry_bindings places them at their kGeomBind* indices
// (shader_bindings.h), to which each shader appends its own.
struct GpuGeometryBuffers {
  const GpuBuffer *pages, *locations, *meshes, *instances, *visible, *vis;
};
std::vector<GpuBinding> geometry_bindings(const GpuGeometryBuffers& g);

// The buffers the passes read and write, owned by the caller: the geometry and the raster
// counters (kRasterBindCounters).
struct GpuRasterBuffers {
  GpuGeometryBuffers geometry;
  const GpuBuffer* counters;
};

struct GpuRasterRequest {
  GpuRasterMode mode = GpuRasterMode::kSw;
  uint32_t first_visible = 0, visible_count = 0;
  uint32_t width = 0, height = 0;
  float z_near = 0.01f;
  float pixels_per_unit_at_1 = 1;
  float hw_min_triangle_area_px = kAutoHwMinTriangleAreaPx;
  bool cull_backfaces = true;
};

// Records the raster of visible[first, first + count) into `vis`: the split (every mode: it
// also counts), the compute rasterizer over the clusters it owns (unless kHw), then one
// vkCmdDrawIndirectCount of the hardware clusters (unless kSw). Between prepare and submit.
void record_gpu_raster(GpuRecorder& rec, GpuRasterPasses& passes, const GpuRasterBuffers& buffers,
                       const GpuRasterRequest& request);
// After record_gpu_raster's commands ran (continue_commands): the compute rasterizer's
// deferred big triangles, each box cut into kGpuRasterTileSize² tiles on the host and drawn by
// the tile pass (spec/raster.md §13.5), recorded into `rec` (continue_commands between
// dispatches of kGpuRasterTilesPerDispatch tiles). Adds the tiled triangles and tiles to
// `split`. Throws GPU_SCENE_TOO_LARGE beyond kGpuRasterMaxBigTriangles big triangles.
void record_gpu_raster_tiles(GpuRecorder& rec, GpuRasterPasses& passes, const GpuRasterBuffers& buffers,
                             const GpuRasterRequest& request, RasterSplitStats* split);
// The virtual shadow pages (spec/shadow.md §5) by the compute rasterizer: `geometry.visible`
// holds the elements (one per cluster and page it is drawn into), `geometry.instances` one
// GpuInstance per (view, instance), `element_page` each element's index into `pages`
// (GpuShadowPage), whose texels are atomicMax'ed into `pool` (float bits; the caller clears
// the drawn slots). The record_gpu_raster / record_gpu_raster_tiles pair for shadow pages:
// the cluster pass, then (after continue_commands) the deferred big triangles' tiles.
struct GpuShadowRasterBuffers {
  GpuRasterBuffers raster;
  const GpuBuffer *pages, *element_page, *pool;
};
void record_gpu_shadow_raster(GpuRecorder& rec, GpuRasterPasses& passes, const GpuShadowRasterBuffers& buffers,
                              uint32_t element_count);
void record_gpu_shadow_raster_tiles(GpuRecorder& rec, GpuRasterPasses& passes, const GpuShadowRasterBuffers& buffers,
                                    uint32_t element_count, RasterSplitStats* split);

// The virtual shadow pages by the hardware raster (spec/shadow.md §8): one draw per element
// (3 · its triangles, firstInstance = the element), in its page's mip viewport and scissored to
// the page; the fragment translates its virtual texel through `page_table` (the frame's slot
// per entry; GpuShadowPage::table_offset/table_side) and atomicMax'es the depth bits into the
// pool slot. `draws` grouped by page. No continue_commands needed (no deferred triangles).
struct GpuShadowHwDraw {
  uint32_t element = 0, triangles = 0, page = 0;
};
void record_gpu_shadow_hw_raster(GpuRecorder& rec, GpuRasterPasses& passes, const GpuShadowRasterBuffers& buffers,
                                 const GpuBuffer& page_table, const std::vector<GpuShadowPage>& pages,
                                 const std::vector<GpuShadowHwDraw>& draws);

// After submit_and_wait: the split of the last recorded range.
RasterSplitStats read_gpu_raster_split(const GpuRasterPasses& passes);

}  // namespace vgeo
