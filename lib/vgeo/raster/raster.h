#pragma once
// Software rasterizer (spec/raster.md): fixed point with kSubpixelBits sub-pixel bits (as
// Vulkan/lavapipe), top-left fill rule, half-space edge functions; per triangle either a
// micropoly bounding-box loop or a scanline path; back-face culling; triangles crossing
// the near plane are clipped (never rasterized unclipped). Writes VisBuffer keys.
#include <cstdint>

#include "vgeo/core/math.h"
#include "vgeo/raster/visbuffer.h"

namespace vgeo {

inline constexpr int kSubpixelBits = 8;

// Largest supported viewport side (pixels). With kGuardBandNdc it bounds every snapped
// coordinate below 2^28 sub-pixel units, so edge functions are exact in int64
// (spec/raster.md, "Exact ranges"). Larger targets are a programming error.
inline constexpr uint32_t kMaxRasterViewport = 16384;
// Guard band half-extent in NDC units: triangles reaching beyond |x|,|y| ≤ 64·w in clip
// space are clipped there, so perspective division and fixed-point conversion never
// overflow. 64 screen widths keeps clipping rare while leaving int64 headroom 2^35.
inline constexpr double kGuardBandNdc = 64.0;

enum class RasterPath : uint8_t {
  kAuto = 0,       // choose per triangle by its screen bounding box
  kMicropoly = 1,  // bounding-box loop: best for tiny triangles
  kScanline = 2,   // per-row span walk: best for large triangles
  kReference = 3,  // brute force over the whole viewport in 64-bit integers (tests, benchmarks)
};

struct RasterOptions {
  RasterPath path = RasterPath::kAuto;
  bool cull_backfaces = true;     // front faces are counter-clockwise (glTF)
  float z_near = 0.01f;           // view-space near plane distance; reversed-Z infinite far
  // Scissor window (the virtual shadow map's pages, spec/shadow.md §5): when virtual_width > 0,
  // triangles are set up in a virtual_width x virtual_height viewport and only its pixels
  // [window_x, window_x + target.width) x [window_y, window_y + target.height) are visited,
  // written to the target at (px - window_x, py - window_y). The pixels written are exactly
  // those a full-size target would get there. 0: the target is the whole viewport.
  uint32_t virtual_width = 0, virtual_height = 0;
  uint32_t window_x = 0, window_y = 0;
};

struct RasterStats {
  uint64_t triangles_in = 0, triangles_culled = 0, triangles_clipped = 0;
  uint64_t micropoly_triangles = 0, scanline_triangles = 0, pixels_written = 0;
  // Added (additive): subset of triangles_culled dropped as invalid (non-finite clip
  // coordinates, vertex index out of range, id limits exceeded). spec/raster.md.
  uint64_t triangles_invalid = 0;
  void add(const RasterStats& o) {
    triangles_invalid += o.triangles_invalid;
    triangles_in += o.triangles_in; triangles_culled += o.triangles_culled;
    triangles_clipped += o.triangles_clipped; micropoly_triangles += o.micropoly_triangles;
    scanline_triangles += o.scanline_triangles; pixels_written += o.pixels_written;
  }
};

// Rasterizes one cluster's triangles. `positions` are object-space xyz (3 floats per
// vertex), `indices` 3 local indices per triangle, `object_to_clip` maps to clip space
// with the reversed-Z infinite-far projection (clip.w = view depth, clip.z = z_near),
// so NDC depth = z_near / view_depth ∈ (0, 1]. Each covered pixel gets
// pack_vis_key(depth, visible_cluster, triangle index) via VisBuffer::write_max.
// Thread-safe: concurrent calls on the same VisBuffer are fine.
void rasterize_cluster(VisBuffer& target, const float* positions, uint32_t vertex_count,
                       const uint8_t* indices, uint32_t triangle_count, const Mat4& object_to_clip,
                       uint32_t visible_cluster, const RasterOptions& options, RasterStats* stats);

// Reversed-Z infinite-far perspective projection (right-handed view space looking down −Z).
Mat4d perspective_reversed_z(double fov_y_radians, double aspect, double z_near);

}  // namespace vgeo
