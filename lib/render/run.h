#pragma once
// One call that renders a scene's frames and reports per-frame statistics: what
// `vgeo render` and `vgeo demo` run.
#include <cstdint>
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
};

struct RenderReport {
  std::vector<FrameStats> frames;
  uint32_t width = 0, height = 0;
  uint64_t image_hash = 0;                // FNV-1a of the last frame's RGB bytes
  uint64_t vis_hash = 0;                  // FNV-1a of the last frame's visibility-buffer keys
  std::string table() const;              // last frame's pass table (+ medians over frames)
  std::string json() const;               // {"frames":[...], ...}
};

// Throws VgeoError (e.g. RENDER_BAD_CAMERA for a --camera out of range).
RenderReport render_scene(const SceneFile& scene, const RenderRequest& request);

// `vgeo demo` entry point: builds (or loads from `cache_dir`, may be empty) the embedded
// default scene at width x height and renders it.
RenderReport render_default_scene(const RenderRequest& request, uint32_t width = 1280, uint32_t height = 720,
                                  const std::string& cache_dir = "");

}  // namespace vgeo
