#pragma once
// `vgeo render --backend cpu|vulkan [--compare cpu]` (spec/gpu.md §Backends, the rule in
// spec/raster.md §Backends agree): renders a scene's frames from its memory form (one
// encoding per mesh: the CPU reference draws its decode, Vulkan its pages) on either backend,
// or on both and compares them frame by frame.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vgeo/gpu/context.h"
#include "vgeo/gpu/gpu_cull.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/gpu/hw_raster.h"
#include "vgeo/raster/hw_rule.h"
#include "vgeo/render/scene_file.h"

namespace vgeo {

enum class Backend : uint8_t { kCpu, kVulkan };
bool parse_backend(const std::string& name, Backend* out);
const char* backend_name(Backend backend);

struct BackendRunRequest {
  Backend backend = Backend::kCpu;
  bool compare_cpu = false;          // render every frame on the CPU too and compare
  GpuRasterMode raster = GpuRasterMode::kSw;  // Vulkan: which GPU rasterizer draws each cluster
  GpuOptions gpu;
  GpuTraversal traversal = kDefaultGpuTraversal;  // the Vulkan cull's BVH traversal
  unsigned threads = 0;
  uint32_t frames = 0;               // 0: the camera path's length if any, else 1
  uint32_t camera = 0;
  std::optional<float> threshold_px;
  std::optional<ShadeView> view;
  std::optional<bool> occlusion;
  std::string output_png;            // last frame of `backend`
  std::string diff_png;              // with compare_cpu: per-pixel differences of the last frame
  // With compare_cpu: for every frame that breaks the rule, write frame_NNNNN_diff.png and
  // frame_NNNNN_pixels.txt (x y and both sides' denoted keys of each differing pixel) here.
  std::string failure_dir;
};

// One frame of a comparison (spec/raster.md §Backends agree; with a hardware-rastered
// cluster in the frame, the hardware rule of §13.3 instead of bit identity).
struct FrameComparison {
  bool clusters_equal = true;        // same selected (instance, cluster) set
  uint64_t vis_pixels_differing = 0; // pixels whose key denotes a different (depth, instance, cluster, triangle)
  bool shaded = false;               // the image was compared (last frame)
  int max_channel_diff = 0;          // in 1/255 units (hardware rule: pixels with identical keys only)
  uint64_t pixels_over = 0;          // pixels with a channel more than 1/255 apart
  bool hw_rule = false;              // judged by the hardware rule (--raster hw|auto)
  HwRasterAgreement hw;              // per-pixel classes of the hardware rule
  bool holds() const {
    return clusters_equal && (hw_rule ? hw.failures() == 0 : vis_pixels_differing == 0) && max_channel_diff <= 1;
  }
};

struct BackendRunReport {
  Backend backend = Backend::kCpu;
  std::string device;                // GPU name (Vulkan)
  std::vector<FrameStats> frames;    // of `backend`
  GpuRasterMode raster = GpuRasterMode::kSw;
  std::vector<RasterSplitStats> raster_split;  // Vulkan: per frame, clusters/triangles per raster path
  uint32_t width = 0, height = 0;
  uint64_t vis_hash = 0, cluster_set_hash = 0, image_hash = 0;  // last frame (spec/raster.md §Hashes)
  std::vector<FrameComparison> comparisons;  // per frame, with compare_cpu
  bool rule_holds = true;
  std::vector<std::string> validation_messages;
  GpuPoolStats pool;                 // streamed Vulkan runs: the GPU page pool
  std::string table() const;
  std::string json() const;
};

// Both backends draw the scene's own memory form (spec/raster.md §Backends agree): the CPU
// reference its decode (scene.scene), Vulkan its pages (memory_form_pages(scene)); a streamed
// scene's page-file meshes from each renderer's resident pages. Throws VgeoError: GPU_*
// (gpu.md), RENDER_BAD_OPTION / RENDER_BAD_CAMERA as render_scene, the Streamer's errors for a
// streamed scene.
BackendRunReport run_backend(const SceneFile& scene, const BackendRunRequest& request);
// The same with the scene's pages already transcoded (memory_form_pages(scene); unused, and
// may be empty, on the CPU backend) and, when `gpu` is given, an existing context instead of
// one from request.gpu (the golden test renders each scene under several --raster modes).
BackendRunReport run_backend(const SceneFile& scene, const MemoryFormPages& pages, const BackendRunRequest& request,
                             GpuContext* gpu = nullptr);

// spec/raster.md §Hashes. Both are independent of the visible-cluster list's order.
uint64_t vis_buffer_hash(const VisBuffer& vis, const std::vector<VisibleCluster>& visible);
uint64_t cluster_set_hash(const std::vector<VisibleCluster>& visible);

}  // namespace vgeo
