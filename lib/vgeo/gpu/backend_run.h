#pragma once
// `vgeo render --backend cpu|vulkan [--compare cpu]` (spec/gpu.md §Backends, the rule in
// spec/raster.md §Backends agree): the Vulkan backend as a FrameRenderer (render/run.h), and
// the entry point that picks the request's backend and runs the one frame loop, run_frames.
// Both backends draw the scene's own memory form: the CPU reference its decode (the scene's
// meshes), Vulkan its pages (memory_form_pages); a streamed scene's page-file meshes from each
// renderer's resident pages.
#include <memory>

#include "vgeo/gpu/context.h"
#include "vgeo/gpu/gpu_cull.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/gpu/hw_raster.h"
#include "vgeo/render/run.h"

namespace vgeo {

// What a caller may share between renders (the golden test renders each scene under several
// --raster modes): an existing context instead of one from the request's gpu_device /
// gpu_validate, and the scene's pages already transcoded (memory_form_pages(scene)).
struct BackendResources {
  GpuContext* gpu = nullptr;
  const MemoryFormPages* pages = nullptr;
};

// The Vulkan backend (gpu_frame.h's executor) on `file`'s scene, streamed from its own
// Streamer when the scene streams (`synchronous_stream`: the deterministic loader). Its
// finish() reports the device, the --raster mode, the GPU page pool and the validation
// messages of its frames. Throws GPU_* (spec/gpu.md).
std::unique_ptr<FrameRenderer> make_vulkan_renderer(const SceneFile& file, const RenderRequest& request,
                                                    const RenderSettings& settings, ThreadPool& pool,
                                                    bool synchronous_stream, const BackendResources& shared = {});

// Renders `file` on request.backend through run_frames; with compare_cpu (Vulkan only) the CPU
// reference renders every frame too and both stream with the deterministic loader, so both
// install the same pages in the same frame. Throws VgeoError: GPU_* (gpu.md),
// RENDER_BAD_OPTION / RENDER_BAD_CAMERA (resolve_render_options), the Streamer's errors.
RenderReport run_backend(const SceneFile& file, const RenderRequest& request, const BackendResources& shared = {},
                         const FrameCallback& on_frame = {});

}  // namespace vgeo
