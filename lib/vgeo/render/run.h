#pragma once
// The frame loop of `vgeo render`, `vgeo demo` and the golden tests, one for every backend
// (spec/gpu.md §Backends): run_frames owns the frames (which camera, which are shaded),
// pacing, saving PNGs, the streaming summary, the hashes and the frame-by-frame comparison
// with a reference renderer. A backend is a FrameRenderer: it renders one frame (plan and
// execute, lib/vgeo/render/frame_plan.h) and says what only it knows. The CPU reference's
// renderer is here (make_cpu_renderer); the Vulkan one is lib/vgeo/gpu/backend_run.h.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "vgeo/render/compare.h"
#include "vgeo/render/scene_file.h"
#include "vgeo/render/streaming.h"

namespace vgeo {

enum class Backend : uint8_t { kCpu, kVulkan };
bool parse_backend(const std::string& name, Backend* out);
const char* backend_name(Backend backend);

// Declared with their values in lib/vgeo/gpu (hw_raster.h, gpu_cull.h); value 0 is the default.
enum class GpuRasterMode : uint8_t;  // 0: kSw, the compute rasterizer
enum class GpuTraversal : uint8_t;

// Everything a render asks for, on any backend (`vgeo render`'s options).
struct RenderRequest {
  // Which frames: `frames` 0 = the camera path's length if any, else 1 (frames past the path
  // hold its last camera); `camera`: the scene camera when there is no path.
  uint32_t frames = 0;
  uint32_t camera = 0;
  unsigned threads = 0;                   // 0: hardware concurrency; output identical for any value
  // Overrides of the scene's settings.
  std::optional<float> threshold_px;      // τ (settings.tau_px)
  std::optional<ShadeView> view;          // default lit
  std::optional<bool> occlusion;
  // Frame pacing: when > 0, frame f+1 starts no earlier than this many ms after frame f started
  // (a display's refresh interval, e.g. 16.7). Only wall time changes, never the output; with
  // the asynchronous loader it fixes how many simulated reads fit in a frame.
  double frame_interval_ms = 0;
  // Output: the LAST frame's image to `output_png` (empty: none); with `out_dir`, frame f is
  // shaded and written as out_dir/frame_NNNNN.png for f % save_every == 0 (save_every > 0)
  // and for the last frame. Only frames whose image is kept are shaded.
  std::string output_png;
  std::string out_dir;
  uint32_t save_every = 0;
  // Backend (spec/gpu.md): the CPU reference or Vulkan; with compare_cpu (Vulkan only) every
  // frame is rendered on the CPU too and compared (spec/raster.md §Backends agree).
  Backend backend = Backend::kCpu;
  bool compare_cpu = false;
  std::string diff_png;                   // with compare_cpu: the last frame's differences
  // With compare_cpu: for every frame that breaks the rule, frame_NNNNN_diff.png and
  // frame_NNNNN_pixels.txt (x y and both sides' denoted keys of each differing pixel) here.
  std::string failure_dir;
  // Vulkan only.
  std::string gpu_device;                 // index or name substring (GpuOptions::device)
  bool gpu_validate = false;              // the validation layer; any message fails
  GpuRasterMode raster{};                 // which GPU rasterizer draws each cluster (hw_raster.h)
  std::optional<GpuTraversal> traversal;  // the Vulkan cull's BVH traversal; default kDefaultGpuTraversal
};

// The scene's settings with the request's overrides, and the frame count (`*frames`): the one
// check of render options. Throws RENDER_BAD_OPTION (τ not positive and finite, more than
// kMaxPathFrames frames) and RENDER_BAD_CAMERA (no such camera).
RenderSettings resolve_render_options(const SceneFile& file, const RenderRequest& request, uint32_t* frames);

// One renderer's streaming state for a streamed scene (SceneFile::streaming): a private copy
// of the scene (metadata-only page-file meshes; in-memory meshes move into the geometry), its
// own Streamer over the scene's page files and the FrameStreaming the frames use. Each
// renderer of a comparison has its own (spec/gpu.md §Streaming). Not movable (the
// FrameStreaming points at the Streamer). `synchronous`: force the deterministic loader.
struct SceneStreaming {
  RenderScene scene;
  std::unique_ptr<Streamer> streamer;
  FrameStreaming frame;
};
// Throws as the Streamer's constructor, and RENDER_PLAN_MISMATCH when the streamer finds the
// data within the budget the scene exceeds.
std::unique_ptr<SceneStreaming> start_scene_streaming(const SceneFile& file, float threshold_px, bool synchronous);

// Streaming summary over all frames.
struct StreamSummary {
  bool requested = false;        // a budget was given
  bool active = false;           // streaming ran
  std::string note;              // one line: "streaming: off (data ... ≤ budget)" etc.
  uint64_t budget_bytes = 0, page_bytes = 0;  // page_bytes: memory form of the used meshes
  uint64_t file_bytes = 0;       // sum of the streamed files' sizes
  uint64_t bytes_read = 0, pages_loaded = 0, pages_evicted = 0, faults = 0, pages_marked_bad = 0;
  uint64_t peak_reserved_bytes = 0;
  uint32_t popin_frames = 0;     // frames whose cut was coarser than the ideal one
  uint32_t stop_frame = 0;       // first frame of the final (unchanging) camera
  // Of bytes_read / pages_loaded, those completed in frames ≥ stop_frame (the rest: while moving).
  uint64_t bytes_read_after_stop = 0, pages_loaded_after_stop = 0;
  uint64_t stop_required_bytes = 0;  // required_bytes of the last frame: budget ≥ this ⇒ converges
  int64_t frames_to_converge = -1;  // after stop_frame, until every later frame is ideal; -1 never
  double median_frame_ms = 0;
};

// A streamed Vulkan renderer's GPU page pool (spec/gpu.md §Streaming), since its creation.
struct GpuPoolStats {
  uint32_t slots = 0;
  uint64_t pool_bytes = 0, pages_uploaded = 0, pages_freed = 0, bytes_uploaded = 0;
};

struct RenderReport {
  Backend backend = Backend::kCpu;
  std::string device;                     // the GPU's name (Vulkan)
  std::string raster;                     // Vulkan: the --raster mode's name
  std::vector<FrameStats> frames;         // of the request's backend
  uint32_t width = 0, height = 0;
  // Of the last frame (spec/raster.md §Hashes): vis_hash and cluster_set_hash are independent
  // of the visible list's order, so every backend gives the same for the same frame.
  uint64_t vis_hash = 0, cluster_set_hash = 0, image_hash = 0;
  StreamSummary stream;
  std::vector<std::string> saved_pngs;
  std::vector<FrameComparison> comparisons;  // per frame, with compare_cpu
  bool rule_holds = true;
  std::vector<std::string> validation_messages;  // Vulkan with validation
  GpuPoolStats pool;                      // streamed Vulkan runs
  std::string table() const;              // streaming table, last frame's pass table, medians, hashes, comparison
  std::string json() const;               // {"backend", ..., "frames":[...], ...} (spec/gpu.md §Backends)
  std::string stream_table() const;       // per-frame streaming metrics + summary (empty without a budget)
};

// A backend: renders one frame of its own copy of the scene (plan and execute) and keeps what
// a frame leaves for the next (history, streaming state).
class FrameRenderer {
 public:
  virtual ~FrameRenderer() = default;
  // Renders `camera` into `out` (Frame::stats.total_ms: the frame's wall time).
  virtual void render(const Camera& camera, const RenderSettings& settings, bool has_next_frame, Frame* out) = 0;
  // What the frames are drawn from (the comparison's exact model reads them).
  virtual const RenderScene& scene() const = 0;
  virtual const FrameStreaming* streaming() const = 0;  // null when not streamed
  const std::vector<ClusterDag>& geometry() const { return streaming() ? streaming()->geometry : scene().meshes; }
  // Before frame `frame`: the scene file's moves of that frame (spec/scene.md §Moves) applied
  // to the renderer's scene, which keeps them.
  virtual void apply_moves(uint32_t frame) { (void)frame; }
  // After the last frame: what only the backend knows (device, page pool, messages).
  virtual void finish(RenderReport* report) { (void)report; }
};

// What every backend's renderer has: the scene file, the thread pool, its own streaming state
// for a streamed scene (start_scene_streaming; `synchronous_stream`: the deterministic loader,
// as a comparison needs) and its own history; frame_inputs() is one frame's FrameInputs.
class SceneFrameRenderer : public FrameRenderer {
 public:
  SceneFrameRenderer(const SceneFile& file, const RenderSettings& settings, ThreadPool& pool, bool synchronous_stream);
  const RenderScene& scene() const override {
    return streaming_ ? streaming_->scene : moved_ ? *moved_ : file_.scene;
  }
  void apply_moves(uint32_t frame) override;
  const FrameStreaming* streaming() const override { return streaming_ ? &streaming_->frame : nullptr; }

 protected:
  FrameInputs frame_inputs(const Camera& camera, const RenderSettings& settings, bool has_next_frame);
  const SceneFile& file_;
  ThreadPool& pool_;
  std::unique_ptr<SceneStreaming> streaming_;
  // A scene with moves and no streaming: the renderer's own copy, moved frame by frame (a
  // streamed scene is moved in streaming_->scene, already the renderer's own).
  std::unique_ptr<RenderScene> moved_;
  FrameHistory history_;
};

// The CPU reference (frame.cpp) on `file`'s scene, streamed from its own Streamer when the
// scene streams (`synchronous_stream`: the deterministic loader, as a comparison needs).
std::unique_ptr<FrameRenderer> make_cpu_renderer(const SceneFile& file, const RenderSettings& settings,
                                                 ThreadPool& pool, bool synchronous_stream);

// Sees every frame after it is rendered (tests check each frame's cut).
using FrameCallback = std::function<void(uint32_t, const Frame&, const FrameStreaming*)>;

// The frame loop: renders `file`'s frames on `renderer` (and on `reference`, when given,
// comparing each frame: RenderReport::comparisons). Throws VgeoError as the renderers do.
RenderReport run_frames(const SceneFile& file, const RenderRequest& request, const RenderSettings& settings,
                        uint32_t frames, FrameRenderer& renderer, FrameRenderer* reference,
                        const FrameCallback& on_frame = {});

// The CPU backend through run_frames (request.backend must be kCpu; the Vulkan backend and
// comparisons: run_backend, lib/vgeo/gpu/backend_run.h). Throws VgeoError (e.g.
// RENDER_BAD_CAMERA for a --camera out of range).
RenderReport render_scene(const SceneFile& scene, const RenderRequest& request, const FrameCallback& on_frame = {});

// Sizes: a non-negative integer with an optional unit B, KiB, MiB, GiB (×1024^k) or KB, MB,
// GB (×1000^k), e.g. "64MiB", "512KiB", "1GB", "4096". false when malformed or > 2^62.
bool parse_byte_size(const std::string& text, uint64_t* out);
std::string format_bytes(uint64_t bytes);  // "3.1 MiB"

// `vgeo demo` / `vgeo render` without a scene: the embedded default scene at width x height
// (built or loaded from `cache_dir`, may be empty), with request.frames frames of its path.
SceneFile load_default_scene(const RenderRequest& request, uint32_t width = 1280, uint32_t height = 720,
                             const std::string& cache_dir = "");

}  // namespace vgeo
