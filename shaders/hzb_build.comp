#version 460
// HZB build (hzb.cpp build_hzb): push.mode == 0: mip 0 = the depth of each visibility-buffer
// key (its high 32 bits, float bits); else mip `push.mode` = min of the 2x2 texels of the
// previous mip it covers, clamped at the edge (odd sizes). Depths are ≥ 0 and never NaN, so
// the float min is exact and order-free.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types : require
#include "vgeo/core/cull_shared.h"
#include "vgeo/gpu/shader_bindings.h"

layout(local_size_x = VGEO_HZB_GROUP_SIZE) in;
layout(std430, binding = kHzbBindParams) readonly buffer ParamsBuf { GpuCullParams params; };
layout(std430, binding = kHzbBindVis) readonly buffer VisBuf { uint32_t vis[]; };  // uint64 keys as (low, high) pairs
layout(std430, binding = kHzbBindHzb) buffer HzbBuf { uint32_t hzb[]; };
layout(push_constant) uniform Push { GpuCullPush push; };

void main() {
  uint level = push.mode;
  uint w = params.hzb_mip_width[level], h = params.hzb_mip_height[level];
  uint i = gl_GlobalInvocationID.x;
  if (i >= w * h) return;
  uint x = i % w, y = i / w;
  if (level == 0u) {
    hzb[params.hzb_mip_offset[0] + i] = vis[2u * i + 1u];
    return;
  }
  uint pw = params.hzb_mip_width[level - 1u], ph = params.hzb_mip_height[level - 1u];
  uint src = params.hzb_mip_offset[level - 1u];
  uint x0 = 2u * x, y0 = 2u * y, x1 = min(x0 + 1u, pw - 1u), y1 = min(y0 + 1u, ph - 1u);
  float a = uintBitsToFloat(hzb[src + y0 * pw + x0]), b = uintBitsToFloat(hzb[src + y0 * pw + x1]);
  float c = uintBitsToFloat(hzb[src + y1 * pw + x0]), d = uintBitsToFloat(hzb[src + y1 * pw + x1]);
  float ab = (b < a) ? b : a, cd = (d < c) ? d : c;  // std::min(std::min(a, b), std::min(c, d))
  hzb[params.hzb_mip_offset[level] + i] = floatBitsToUint((cd < ab) ? cd : ab);
}
