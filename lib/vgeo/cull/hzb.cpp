// Hierarchical depth buffer: a max-depth mip chain of the visibility buffer, tested by a
// sphere's screen rectangle. Based on: Greene, Kass, Miller, "Hierarchical Z-Buffer
// Visibility", SIGGRAPH 1993; used two-pass as in Karis et al., "Nanite: A Deep Dive" (2021).
#include "vgeo/cull/hzb.h"

#include <algorithm>
#include <cassert>

#include "vgeo/core/vis_key.h"

namespace vgeo {

// kHzbDepthMargin (vgeo/core/cull_shared.h, shared with the shaders): relative depth margin:
// an object is occluded only if its nearest depth is below the HZB depth by more than this.
// Covers the rasterizer's float depth interpolation (a few ulps) and the float view-space
// sphere (kConservativeRelativeSlack is larger than both). Equal depths are never culled:
// ties in the visibility buffer resolve by id.

void build_hzb(const uint64_t* keys, uint32_t width, uint32_t height, ThreadPool& pool, Hzb* out) {
  out->width = width;
  out->height = height;
  out->mips.clear();
  out->mip_width.clear();
  out->mip_height.clear();
  if (width == 0 || height == 0) return;
  out->mips.emplace_back(size_t(width) * height);
  out->mip_width.push_back(width);
  out->mip_height.push_back(height);
  {
    float* d = out->mips[0].data();
    pool.parallel_for(height, [&](size_t y) {
      for (uint32_t x = 0; x < width; ++x) d[y * width + x] = vis_key_depth(keys[y * width + x]);
    });
  }
  while (out->mip_width.back() > 1 || out->mip_height.back() > 1) {
    uint32_t pw = out->mip_width.back(), ph = out->mip_height.back();
    uint32_t w = (pw + 1) / 2, h = (ph + 1) / 2;
    std::vector<float> next(size_t(w) * h);
    const std::vector<float>& prev = out->mips.back();
    pool.parallel_for(h, [&](size_t y) {
      for (uint32_t x = 0; x < w; ++x) {
        uint32_t x0 = 2 * x, y0 = uint32_t(2 * y);
        uint32_t x1 = std::min(x0 + 1, pw - 1), y1 = std::min(y0 + 1, ph - 1);
        float m = std::min(std::min(prev[size_t(y0) * pw + x0], prev[size_t(y0) * pw + x1]),
                           std::min(prev[size_t(y1) * pw + x0], prev[size_t(y1) * pw + x1]));
        next[y * w + x] = m;
      }
    });
    out->mips.push_back(std::move(next));
    out->mip_width.push_back(w);
    out->mip_height.push_back(h);
  }
}

bool hzb_occludes(const Hzb& hzb, const Sphere& s, const ViewParams& view, HzbMipPolicy policy) {
  if (hzb.empty() || s.radius < 0) return false;
  if (hzb.width != view.width || hzb.height != view.height) return false;
  if (sphere_crosses_near(s, view)) return false;
  ScreenRect rect = sphere_screen_rect(s, view);
  if (rect.empty()) return false;  // off screen: frustum culling's business
  double nearest = sphere_nearest_depth(s, view);
  if (!(nearest > 0) || !std::isfinite(nearest)) return false;
  uint32_t max_span = policy == HzbMipPolicy::k4x4 ? 4 : 2;
  uint32_t level = 0;
  if (policy != HzbMipPolicy::kFinest) {
    while (level + 1 < hzb.mips.size() &&
           (((uint32_t(rect.x1) >> level) - (uint32_t(rect.x0) >> level) + 1 > max_span) ||
            ((uint32_t(rect.y1) >> level) - (uint32_t(rect.y0) >> level) + 1 > max_span)))
      ++level;
  }
  uint32_t w = hzb.mip_width[level];
  const std::vector<float>& mip = hzb.mips[level];
  float farthest = 1e30f;
  for (uint32_t y = uint32_t(rect.y0) >> level; y <= (uint32_t(rect.y1) >> level); ++y)
    for (uint32_t x = uint32_t(rect.x0) >> level; x <= (uint32_t(rect.x1) >> level); ++x)
      farthest = std::min(farthest, mip[size_t(y) * w + x]);
  return nearest * (1 + kHzbDepthMargin) < double(farthest);
}

}  // namespace vgeo
