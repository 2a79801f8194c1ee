// The Vulkan FrameRenderer and the backend entry point (backend_run.h).
#include "vgeo/gpu/backend_run.h"

#include <mutex>

#include "vgeo/core/error.h"

namespace vgeo {

namespace {

class VulkanFrameRenderer final : public SceneFrameRenderer {
 public:
  VulkanFrameRenderer(const SceneFile& file, const RenderRequest& request, const RenderSettings& settings,
                      ThreadPool& pool, bool synchronous_stream, const BackendResources& shared)
      : SceneFrameRenderer(file, settings, pool, synchronous_stream), raster_(request.raster), gpu_(shared.gpu) {
    if (!gpu_) {
      GpuOptions options;
      options.device = request.gpu_device;
      options.validate = request.gpu_validate;
      own_gpu_ = create_gpu_context(options);
      gpu_ = own_gpu_.get();
    }
    {
      std::lock_guard<std::mutex> lock(gpu_->messages_mutex);
      first_message_ = gpu_->validation_messages.size();
    }
    MemoryFormPages own_pages;
    const MemoryFormPages* pages = shared.pages;
    if (!pages) {
      own_pages = memory_form_pages(file);
      pages = &own_pages;
    }
    GpuRendererOptions options;
    options.raster = request.raster;
    const GpuTraversal traversal = request.traversal.value_or(kDefaultGpuTraversal);
    renderer_ = streaming_ ? create_gpu_renderer_streamed(*gpu_, streaming_->scene, streaming_->frame, *pages,
                                                          traversal, options)
                           : create_gpu_renderer(*gpu_, file.scene, *pages, traversal, options);
  }

  void render(const Camera& camera, const RenderSettings& settings, bool has_next_frame, Frame* out) override {
    render_frame_vulkan(*renderer_, frame_inputs(camera, settings, has_next_frame), out);
  }

  void finish(RenderReport* report) override {
    report->device = gpu_->device_name;
    report->raster = gpu_raster_mode_name(raster_);
    if (streaming_) report->pool = gpu_pool_stats(*renderer_);
    renderer_.reset();  // its buffers' destruction may report too
    std::lock_guard<std::mutex> lock(gpu_->messages_mutex);
    report->validation_messages.assign(gpu_->validation_messages.begin() + first_message_,
                                       gpu_->validation_messages.end());
  }

 private:
  GpuRasterMode raster_;
  std::unique_ptr<GpuContext> own_gpu_;
  GpuContext* gpu_;
  size_t first_message_ = 0;
  GpuRendererPtr renderer_;
  FrameHistory history_;
};

}  // namespace

std::unique_ptr<FrameRenderer> make_vulkan_renderer(const SceneFile& file, const RenderRequest& request,
                                                    const RenderSettings& settings, ThreadPool& pool,
                                                    bool synchronous_stream, const BackendResources& shared) {
  return std::make_unique<VulkanFrameRenderer>(file, request, settings, pool, synchronous_stream, shared);
}

RenderReport run_backend(const SceneFile& file, const RenderRequest& request, const BackendResources& shared,
                         const FrameCallback& on_frame) {
  uint32_t frames = 0;
  const RenderSettings settings = resolve_render_options(file, request, &frames);
  const bool vulkan = request.backend == Backend::kVulkan;
  if (request.compare_cpu && !vulkan)
    fail("RENDER_BAD_OPTION", "vgeo render", "--compare cpu needs --backend vulkan", kExitUsage);
  ThreadPool pool(request.threads);
  // The Vulkan renderer first: a missing device fails before the CPU reference loads anything.
  std::unique_ptr<FrameRenderer> renderer =
      vulkan ? make_vulkan_renderer(file, request, settings, pool, request.compare_cpu, shared)
             : make_cpu_renderer(file, settings, pool, false);
  std::unique_ptr<FrameRenderer> reference =
      request.compare_cpu ? make_cpu_renderer(file, settings, pool, true) : nullptr;
  return run_frames(file, request, settings, frames, *renderer, reference.get(), on_frame);
}

}  // namespace vgeo
