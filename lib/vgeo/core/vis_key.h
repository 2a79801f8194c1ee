#ifndef VGEO_CORE_VIS_KEY_H
#define VGEO_CORE_VIS_KEY_H
// The 64-bit visibility-buffer key (Nanite), the one definition both the CPU rasterizer
// and the GLSL shaders include (common C++/GLSL subset, see shared_glsl.h):
//   bits 63..32  depth: reversed-Z (1 at the near plane, → 0 at infinity) as float bits.
//                Written depths are > 0 and finite, so unsigned integer order equals
//                depth order and 0 means "background". −0, NaN and ≤ 0 are never written.
//   bits 31..7   visible-cluster index (25 bits: at most kMaxVisibleClusters per view)
//   bits  6..0   triangle index within the cluster (7 bits: kMaxClusterTriangles = 128)
// Ties at equal depth resolve to the larger id, so the buffer is identical for any
// thread count, submission order and backend. Normative: spec/raster.md.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"How to depth test?".
#include "vgeo/core/shared_glsl.h"

#ifdef __cplusplus
#include <bit>
namespace vgeo {
#endif

VGEO_CONSTANT uint32_t kVisTriangleBits = 7;
VGEO_CONSTANT uint32_t kVisClusterBits = 32 - kVisTriangleBits;
VGEO_CONSTANT uint32_t kMaxVisibleClusters = 1u << kVisClusterBits;  // 33,554,432
VGEO_CONSTANT uint32_t kVisTriangleMask = (1u << kVisTriangleBits) - 1u;

// `depth_bits` are the IEEE-754 bits of the float depth (C++ std::bit_cast, GLSL
// floatBitsToUint); the key is only ever built from those bits.
VGEO_FUNCTION uint64_t pack_vis_key_bits(uint32_t depth_bits, uint32_t visible_cluster, uint32_t triangle) {
  return (uint64_t(depth_bits) << 32) | (uint64_t(visible_cluster) << kVisTriangleBits) | uint64_t(triangle);
}
VGEO_FUNCTION uint32_t vis_key_depth_bits(uint64_t key) { return uint32_t(key >> 32); }
VGEO_FUNCTION uint32_t vis_key_cluster(uint64_t key) { return uint32_t(key) >> kVisTriangleBits; }
VGEO_FUNCTION uint32_t vis_key_triangle(uint64_t key) { return uint32_t(key) & kVisTriangleMask; }

#ifdef __cplusplus
// C++ conveniences over the float depth (GLSL uses floatBitsToUint / uintBitsToFloat).
inline uint64_t pack_vis_key(float depth, uint32_t visible_cluster, uint32_t triangle) {
  return pack_vis_key_bits(std::bit_cast<uint32_t>(depth), visible_cluster, triangle);
}
inline float vis_key_depth(uint64_t key) { return std::bit_cast<float>(vis_key_depth_bits(key)); }
}  // namespace vgeo
#endif
#endif
