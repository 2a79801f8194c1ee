#pragma once
// The 64-bit visibility buffer (Nanite): one key per pixel, written with atomic max.
//   bits 63..32  depth: reversed-Z (1 at the near plane, → 0 at infinity) as float bits.
//                Written depths are > 0 and finite, so unsigned integer order equals
//                depth order and 0 means "background". −0, NaN and ≤ 0 are never written.
//   bits 31..7   visible-cluster index (25 bits: at most kMaxVisibleClusters per view)
//   bits  6..0   triangle index within the cluster (7 bits: kMaxClusterTriangles = 128)
// Ties at equal depth resolve to the larger id, so the buffer is identical for any
// thread count and submission order. Normative: spec/raster.md.
#include <atomic>
#include <cstdint>
#include <cstring>
#include <vector>

#include "vgeo/dag/cluster_dag.h"

namespace vgeo {

inline constexpr uint32_t kVisTriangleBits = 7;
inline constexpr uint32_t kVisClusterBits = 32 - kVisTriangleBits;
inline constexpr uint32_t kMaxVisibleClusters = 1u << kVisClusterBits;  // 33,554,432
static_assert((1u << kVisTriangleBits) >= kMaxClusterTriangles, "triangle id must fit");

inline uint64_t pack_vis_key(float depth, uint32_t visible_cluster, uint32_t triangle) {
  uint32_t depth_bits;
  std::memcpy(&depth_bits, &depth, 4);
  return (uint64_t(depth_bits) << 32) | (uint64_t(visible_cluster) << kVisTriangleBits) | triangle;
}
inline float vis_key_depth(uint64_t key) {
  uint32_t bits = uint32_t(key >> 32);
  float d;
  std::memcpy(&d, &bits, 4);
  return d;
}
inline uint32_t vis_key_cluster(uint64_t key) { return uint32_t(key) >> kVisTriangleBits; }
inline uint32_t vis_key_triangle(uint64_t key) { return uint32_t(key) & ((1u << kVisTriangleBits) - 1); }

struct VisBuffer {
  uint32_t width = 0, height = 0;
  std::vector<uint64_t> keys;  // width * height, row-major, row 0 at the top; 0 = background

  void resize(uint32_t w, uint32_t h) {
    width = w;
    height = h;
    keys.assign(size_t(w) * h, 0);
  }
  void clear() { std::fill(keys.begin(), keys.end(), 0); }
  // Thread-safe atomic max (C++20 atomic_ref over the plain array the GPU path uploads).
  void write_max(uint32_t x, uint32_t y, uint64_t key) {
    std::atomic_ref<uint64_t> slot(keys[size_t(y) * width + x]);
    uint64_t cur = slot.load(std::memory_order_relaxed);
    while (cur < key && !slot.compare_exchange_weak(cur, key, std::memory_order_relaxed)) {
    }
  }
};

}  // namespace vgeo
