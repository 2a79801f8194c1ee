#pragma once
// One call that renders a scene's frames and reports per-frame statistics: what
// `vgeo render` and `vgeo demo` run.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "vgeo/render/scene_file.h"

namespace vgeo {

struct RenderRequest {
  std::string output_png;                 // empty: no image; else the LAST frame is written here
  unsigned threads = 0;                   // 0: hardware concurrency; output identical for any value
  uint32_t frames = 0;                    // 0: the camera path's length if any, else 1
  uint32_t camera = 0;                    // which scene camera when there is no path
  std::optional<float> threshold_px;      // overrides settings.tau_px
  std::optional<ShadeView> view;          // default lit
  std::optional<bool> occlusion;          // overrides settings.occlusion
  // Streaming (spec/stream.md §Renderer) is the scene's: its options are given once, in
  // SceneLoadOptions::stream, and decided at load (SceneFile::streaming).
  // Frame pacing: when > 0, frame f+1 starts no earlier than this many ms after frame f started
  // (a display's refresh interval, e.g. 16.7). Only wall time changes, never the output; with
  // the asynchronous loader it fixes how many simulated reads fit in a frame.
  double frame_interval_ms = 0;
  // PNGs: when `out_dir` is set, frame f is shaded and written as out_dir/frame_NNNNN.png
  // for f % save_every == 0 (save_every > 0) and for the last frame.
  std::string out_dir;
  uint32_t save_every = 0;
};

// What a request may override of the scene's settings, and which frames it renders.
struct RenderOverrides {
  std::optional<float> threshold_px;
  std::optional<ShadeView> view;
  std::optional<bool> occlusion;
  uint32_t camera = 0, frames = 0;
};
// The scene's settings with the overrides applied, and the frame count (`*frames`): the one
// check of render options for every renderer (render_scene, run_backend). Throws
// RENDER_BAD_OPTION (τ not positive and finite, more than kMaxPathFrames frames) and
// RENDER_BAD_CAMERA (no such camera).
RenderSettings resolve_render_options(const SceneFile& file, const RenderOverrides& overrides, uint32_t* frames);

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

struct RenderReport {
  std::vector<FrameStats> frames;
  uint32_t width = 0, height = 0;
  uint64_t image_hash = 0;                // FNV-1a of the last frame's RGB bytes
  uint64_t vis_hash = 0;                  // FNV-1a of the last frame's visibility-buffer keys
  StreamSummary stream;
  std::vector<std::string> saved_pngs;
  std::string table() const;              // last frame's pass table (+ medians over frames)
  std::string json() const;               // {"frames":[...], ...}
  std::string stream_table() const;       // per-frame streaming metrics + summary (empty without a budget)
};

// Throws VgeoError (e.g. RENDER_BAD_CAMERA for a --camera out of range). `on_frame`, if set,
// sees every frame after it is rendered (tests check each frame's cut).
RenderReport render_scene(const SceneFile& scene, const RenderRequest& request,
                          const std::function<void(uint32_t, const Frame&, const FrameStreaming*)>& on_frame = {});

// Sizes: a non-negative integer with an optional unit B, KiB, MiB, GiB (×1024^k) or KB, MB,
// GB (×1000^k), e.g. "64MiB", "512KiB", "1GB", "4096". false when malformed or > 2^62.
bool parse_byte_size(const std::string& text, uint64_t* out);
std::string format_bytes(uint64_t bytes);  // "3.1 MiB"

// `vgeo demo` entry point: builds (or loads from `cache_dir`, may be empty) the embedded
// default scene at width x height and renders it.
RenderReport render_default_scene(const RenderRequest& request, uint32_t width = 1280, uint32_t height = 720,
                                  const std::string& cache_dir = "");

}  // namespace vgeo
