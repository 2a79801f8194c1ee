#pragma once
// Hierarchical Z-buffer for occlusion culling (Nanite deep dive, "Occlusion culling").
// Built from the visibility buffer's reversed-Z depth: each texel keeps the MINIMUM depth
// (= the farthest surface, 0 = background) of the pixels it covers, so "every covered
// pixel is closer than the object" is a single compare per texel.
// Mip 0 is full resolution; texel (i, j) of mip k covers pixels [i·2^k, (i+1)·2^k) x
// [j·2^k, (j+1)·2^k) clipped to the image (odd sizes round up, out-of-image pixels are ignored).
#include <cstdint>
#include <vector>

#include "vgeo/core/thread_pool.h"
#include "vgeo/cull/view.h"

namespace vgeo {

// Which mip an occlusion test reads (scene setting "hzb_mip_policy", spec/scene.md).
enum class HzbMipPolicy : uint8_t {
  k4x4 = 0,    // finest mip where the rect spans ≤ 4x4 texels (Nanite)
  k2x2 = 1,    // finest mip where the rect spans ≤ 2x2 texels (cheaper, culls less)
  kFinest = 2, // mip 0: exact per-pixel test over the rect (most culling, slowest)
};

struct Hzb {
  uint32_t width = 0, height = 0;
  std::vector<uint32_t> mip_width, mip_height;
  std::vector<std::vector<float>> mips;
  bool empty() const { return mips.empty(); }
};

// keys: width*height visibility-buffer keys (row 0 at the top).
void build_hzb(const uint64_t* keys, uint32_t width, uint32_t height, ThreadPool& pool, Hzb* out);

// True when the sphere is certainly hidden: it lies beyond the near plane and its nearest
// depth is below the farthest depth of every pixel its screen rectangle touches.
// Conservative for the rasterizer's coverage and depth (margins in hzb.cpp).
bool hzb_occludes(const Hzb& hzb, const Sphere& view_sphere, const ViewParams& view,
                  HzbMipPolicy policy);

}  // namespace vgeo
