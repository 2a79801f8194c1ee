#pragma once
// The 64-bit visibility buffer: one key per pixel, written with atomic max. The key layout
// (depth | visible cluster | triangle) is lib/vgeo/core/vis_key.h, shared with the shaders.
// Normative: spec/raster.md.
#include <atomic>
#include <cstdint>
#include <vector>

#include "vgeo/core/vis_key.h"
#include "vgeo/dag/cluster_dag.h"

namespace vgeo {

static_assert((1u << kVisTriangleBits) >= kMaxClusterTriangles, "triangle id must fit");

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
