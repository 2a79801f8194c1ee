#pragma once
// Internal to lib/vgeo/gpu: the Vulkan renderer's state (GpuRenderer: pipelines, per-scene and
// per-frame buffers, the streamed page pool) and the steps its parts share. Made by
// gpu_renderer.cpp (in-memory scenes) and page_pool.cpp (streamed scenes), driven by the frame
// executor (gpu_frame.cpp). Not a public API.
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/gpu/shader_records.h"

namespace vgeo {

struct GpuRenderer {
  GpuContext* gpu = nullptr;
  std::unique_ptr<GpuRecorder> recorder;
  std::unique_ptr<GpuRasterPasses> raster;
  GpuRendererOptions options;
  ComputePipeline shade, shadow_mark, shadow_cull;  // shade.comp, shadow_mark.comp, shadow_cull.comp
  GpuBuffer pages, locations, meshes, materials;
  // Per frame, grown on demand.
  GpuBuffer instances, visible, vis, counters, shade_instances, shade_clusters, overdraw, image;
  // The virtual shadow pages (spec/shadow.md §5, draw_shadow_pages_vulkan): a GpuInstance per
  // (view, instance), the elements (cluster × page), each element's page, the pages drawn
  // (GpuShadowPage) and the physical pool (float bits, ShadowCache::texels' layout).
  GpuBuffer shadow_instances, shadow_elements, shadow_element_page, shadow_pages, shadow_pool;
  // The lit view's lights and shadow maps (shade.comp; GpuLitFrame, GpuShadeLight, GpuShadowMap,
  // the frame's page table).
  GpuBuffer lit_frame, shade_lights, shadow_maps, shadow_table;
  GpuBuffer shadow_needed;  // shadow_mark.comp's marks: uint per page-table entry
  // The shadow views' multi-view cull (shadow_cull.comp, record per GpuShadowCull* record): its
  // views, instances' world spheres, (view, instance) pairs, pages-to-draw tables, work list,
  // provisional flags and request words; the element capacity it last needed.
  GpuBuffer shadow_cull_views, shadow_cull_instances, shadow_cull_pairs, shadow_draw_of_page, shadow_cull_work,
      shadow_provisional, shadow_requests;
  uint32_t shadow_element_capacity = 0;
  // The cull passes (gpu_cull.h): DAG records once, a working set per view size.
  GpuTraversal traversal = kDefaultGpuTraversal;
  GpuCullPipelines cull;
  GpuCullMeshes cull_meshes;
  std::unique_ptr<GpuCullFrame> cull_frame;
  // Streaming: `pages` is a fixed pool of slots of slot_words words (spec/gpu.md §Streaming).
  bool streamed = false;
  uint32_t slot_words = 0;
  std::vector<uint32_t> slot_of_page;  // per container page: its slot, kNone when not in the pool
  std::vector<uint32_t> free_slots;    // descending, so slots are taken lowest first
  GpuPoolStats pool_stats;
};

namespace gpu_detail {

// The geometry buffers, as the cull, raster and shade passes bind them (GpuGeometryBuffers).
inline GpuGeometryBuffers geometry(const GpuRenderer& r) {
  return {&r.pages, &r.locations, &r.meshes, &r.instances, &r.visible, &r.vis};
}

// A new buffer holding `data`.
template <class T>
GpuBuffer upload(GpuContext& gpu, const std::vector<T>& data) {
  GpuBuffer b = create_gpu_buffer(gpu, data.size() * sizeof(T));
  if (!data.empty()) std::memcpy(b.mapped, data.data(), data.size() * sizeof(T));
  return b;
}

// Keeps `buffer` at least `bytes` long (contents not preserved).
void ensure_size(GpuContext& gpu, GpuBuffer& buffer, uint64_t bytes);
// Throws GPU_SCENE_TOO_LARGE when `bytes` exceed one storage buffer (maxStorageBufferRange).
void check_buffer_range(const GpuContext& gpu, uint64_t bytes, const char* what);

// What every renderer has: pipelines, the scene's cull records, raster split infos and materials.
GpuRendererPtr create_renderer_common(GpuContext& gpu, const RenderScene& scene, GpuTraversal traversal,
                                      const GpuRendererOptions& options);
// The record of a mesh drawn with quantization `q`.
GpuMesh gpu_mesh(const MeshQuantization& q, uint32_t first_location, uint32_t material_offset);
// The pages of `in_memory`'s meshes (those `drawn` says), placed from word `first_word` of the
// page buffer into `words`, and their clusters' locations; the meshes' records.
void place_in_memory_pages(const RenderScene& scene, const MemoryFormPages& in_memory, const std::vector<bool>& drawn,
                           uint64_t first_word, std::vector<uint32_t>* words, std::vector<GpuMesh>* meshes,
                           std::vector<GpuClusterLocation>* locations);
// Every mesh's first location: its clusters' locations are consecutive, in mesh order.
std::vector<GpuMesh> mesh_records(const RenderScene& scene, uint64_t* location_count);

// Frees the slots of pages evicted since the last call, then uploads every newly installed
// page into a free slot and points its clusters' locations there. Called at stream_begin,
// after the Streamer installed this frame's reads (residency only grows until stream_end).
// (page_pool.cpp)
void sync_page_pool(GpuRenderer& r, const FrameStreaming& s);

// Row-major rows 0..rows−1 of a Mat4d (GpuShadowMap, GpuLitFrame). (gpu_shadow_cull.cpp)
void put_rows(const Mat4d& m, double* out, int rows);
// The frame's shadow maps (GpuShadowMap per ShadowMapView) into r.shadow_maps (one zero record
// when `shadows` is null or has no map), for shade.comp, shadow_mark.comp and shadow_cull.comp.
// (gpu_shadow_cull.cpp)
void upload_shadow_maps(GpuRenderer& r, const ShadowFrame* shadows);

}  // namespace gpu_detail

}  // namespace vgeo
