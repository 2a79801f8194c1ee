#pragma once
// The Vulkan frame executor (spec/gpu.md §Frame): the frame's passes as lib/vgeo/render
// runs them, with the same pass names, PassStats and Frame result. Today the cull passes
// (instance cull, hierarchical LOD + cluster cull, HZB, pass 2) run on the host through the
// CPU reference; raster (compute, 64-bit atomicMax) and shade run on the GPU, reading the
// memory-form pages as they are. The GPU cull passes replace the host ones when they land.
#include <cstdint>
#include <memory>
#include <vector>

#include "vgeo/format/format.h"
#include "vgeo/gpu/context.h"
#include "vgeo/render/frame.h"

namespace vgeo {

// The scene in the form both backends render (spec/raster.md §Backends agree): every mesh
// encoded once into the page format; `scene` holds the decoded DAGs (quantized positions:
// what the CPU reference draws), `pages` the memory form of the same encoding (what the
// GPU reads). Cluster ids are the original ones in both.
struct MemoryFormScene {
  RenderScene scene;
  std::vector<MeshQuantization> quantization;    // per mesh
  std::vector<std::vector<uint32_t>> pages;      // memory-form words per page
  // Per mesh, per cluster: (page, index of the cluster in that page).
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> cluster_page;
};
// Throws FORMAT_ENCODE (format.h) for meshes the page format cannot represent.
MemoryFormScene make_memory_form_scene(const RenderScene& scene);

struct GpuRenderer;  // pipelines and per-scene GPU buffers (gpu_frame.cpp)
struct GpuRendererDeleter {
  void operator()(GpuRenderer* r) const;
};
using GpuRendererPtr = std::unique_ptr<GpuRenderer, GpuRendererDeleter>;

// Uploads the pages once. Throws GPU_SCENE_TOO_LARGE when the pages exceed one storage
// buffer (maxStorageBufferRange).
GpuRendererPtr create_gpu_renderer(GpuContext& gpu, const MemoryFormScene& scene);

// Renders one frame of `scene.scene` (as render_frame). `out->vis`, `out->image` and the
// raster/shade PassStats come from the GPU; the other passes ran on the host.
void render_frame_vulkan(GpuRenderer& renderer, const MemoryFormScene& scene, const Camera& camera,
                         const RenderSettings& settings, ThreadPool& pool, FrameHistory* history, Frame* out,
                         bool has_next_frame = true);

}  // namespace vgeo
