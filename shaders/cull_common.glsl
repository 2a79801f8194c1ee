// Bindings and the cull arithmetic shared by the cull passes (cull_instances.comp,
// cull_traverse_*.comp, cull_seed.comp, cull_compact.comp). Every function below is the GLSL
// of one function of lib/vgeo/core/lod.h, lib/vgeo/cull/view.h/.cpp or lib/vgeo/cull/hzb.cpp,
// operation for operation (spec/raster.md §12): double where the CPU computes in double,
// `precise` so no multiply-add is contracted, the same comparisons in the same order
// (a NaN takes the same branch), std::min/std::max written as their ternaries.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_EXT_shader_atomic_int64 : require

#include "vgeo/core/cull_shared.h"
#include "vgeo/gpu/shader_bindings.h"

layout(std430, binding = kCullBindParams) readonly buffer ParamsBuf { GpuCullParams params; };
layout(std430, binding = kCullBindMeshes) readonly buffer MeshBuf { GpuCullMesh meshes[]; };
layout(std430, binding = kCullBindClusters) readonly buffer ClusterBuf { GpuCluster clusters[]; };
layout(std430, binding = kCullBindGroups) readonly buffer GroupBuf { GpuGroup groups[]; };
layout(std430, binding = kCullBindNodes) readonly buffer NodeBuf { GpuBvhNode nodes[]; };
layout(std430, binding = kCullBindInstances) readonly buffer InstanceBuf { GpuCullInstance instances[]; };
layout(std430, binding = kCullBindOcclusionInstances) readonly buffer OcclusionInstanceBuf { GpuCullInstance occlusion_instances[]; };
layout(std430, binding = kCullBindHzb) readonly buffer HzbBuf { uint32_t hzb[]; };  // float bits, all mips
layout(std430, binding = kCullBindQueue) coherent buffer QueueBuf { GpuQueueHeader queue; uint64_t slots[]; };
layout(std430, binding = kCullBindBits) coherent buffer BitsBuf { uint32_t bits[]; };
layout(std430, binding = kCullBindCounters) buffer CounterBuf { uint64_t counters[]; };
layout(std430, binding = kCullBindListIn) readonly buffer ListInBuf { uint32_t list_in[]; };
layout(std430, binding = kCullBindListOut) buffer ListOutBuf { uint32_t list_out[]; };
// Streaming words per mesh (GpuCullMesh::stream_base): streams flag, usable, requests.
layout(std430, binding = kCullBindStream) coherent buffer StreamBuf { uint32_t stream_words[]; };

layout(push_constant) uniform Push { GpuCullPush push; };

#include "cull_math.glsl"

// hzb.cpp's k4x4 / k2x2 read: the first mip where the rectangle spans at most max_span
// texels per axis, then its ≤ 4×4 texels (≤ 16 + 20 loop back edges).
float coarse_rect_min(uvec4 r) {
  uint max_span = params.hzb_policy == kHzbPolicy4x4 ? 4u : 2u;
  uint level = 0u;
  while (level + 1u < params.hzb_levels &&
         (((r.z >> level) - (r.x >> level) + 1u > max_span) || ((r.w >> level) - (r.y >> level) + 1u > max_span)))
    ++level;
  uint w = params.hzb_mip_width[level], base = params.hzb_mip_offset[level];
  float farthest = 1e30;
  for (uint y = r.y >> level; y <= (r.w >> level); ++y)
    for (uint x = r.x >> level; x <= (r.z >> level); ++x) {
      float t = uintBitsToFloat(hzb[base + y * w + x]);
      farthest = (t < farthest) ? t : farthest;
    }
  return farthest;
}

// The level of the largest aligned block [a, a + 2^k) inside [a, b] (a 1D dyadic
// decomposition step), capped at the coarsest mip.
uint block_level(uint a, uint b) {
  uint by_alignment = (a == 0u) ? 31u : uint(findLSB(a));
  uint by_length = uint(findMSB(b - a + 1u));
  uint k = by_alignment < by_length ? by_alignment : by_length;
  return k < params.hzb_levels - 1u ? k : params.hzb_levels - 1u;
}

// hzb.cpp's kFinest read, the minimum of every finest texel of the rectangle, computed
// exactly from fewer texels: [x0, x1] and [y0, y1] split into aligned blocks (1D dyadic
// decompositions, at most 2 per level), and each pair of blocks (levels kx, ky) is read from
// mip min(kx, ky), whose texels are exactly the minima of the finest texels they cover
// (build_hzb: 2×2 min, edge clamped). The float minimum is exact and order-free, so the
// value is the CPU's. Reads ≤ 4·(w + h) (spec/raster.md §12), one per loop iteration:
// a single loop, so a vector of invocations costs the maximum of its lanes, not the sum.
float finest_rect_min(uvec4 r) {
  uint xa = r.x, ya = r.y, t = 0u;
  uint kx = block_level(xa, r.z), ky = block_level(ya, r.w);
  float farthest = 1e30;
  while (ya <= r.w) {
    uint k = kx < ky ? kx : ky;
    uint n = 1u << ((kx < ky ? ky : kx) - k);  // texels of mip k in this pair of blocks
    uint x = (xa >> k) + (kx > ky ? t : 0u), y = (ya >> k) + (ky > kx ? t : 0u);
    float v = uintBitsToFloat(hzb[params.hzb_mip_offset[k] + y * params.hzb_mip_width[k] + x]);
    farthest = (v < farthest) ? v : farthest;
    if (++t == n) {
      t = 0u;
      xa += 1u << kx;
      if (xa > r.z) {
        xa = r.x;
        ya += 1u << ky;
        if (ya <= r.w) ky = block_level(ya, r.w);
      }
      kx = block_level(xa, r.z);
    }
  }
  return farthest;
}

// hzb.cpp hzb_occludes (the HZB's size equals the view's: checked on the host).
bool hzb_occludes(Sphere s, GpuCullView v) {
  if (s.radius < 0.0) return false;
  if (double(-s.z) - double(s.radius) <= v.z_near) return false;  // sphere_crosses_near
  ivec4 rect = sphere_screen_rect(s, v);
  if (rect.z < rect.x || rect.w < rect.y) return false;
  precise double nearest = v.z_near / (double(-s.z) - double(s.radius));  // sphere_nearest_depth
  if (!(nearest > 0.0lf) || isinf(nearest) || isnan(nearest)) return false;
  uvec4 r = uvec4(rect);
  float farthest = (params.hzb_policy == kHzbPolicyFinest) ? finest_rect_min(r) : coarse_rect_min(r);
  precise double lhs = nearest * (1.0lf + kHzbDepthMargin);
  return lhs < double(farthest);
}

// cull.cpp occluded(): against the occlusion view and its instance placement.
bool occluded(uint instance, GpuSphere bounds) {
  if ((params.flags & kGpuCullOcclusion) == 0u) return false;
  return hzb_occludes(culling_sphere(occlusion_instances[instance], bounds), params.occlusion_view);
}

void set_bit(uint region, uint key) { atomicOr(bits[region + (key >> 5)], 1u << (key & 31u)); }
