#version 460
// Hardware raster path of the virtual shadow pages, fragment stage (spec/shadow.md §8): the
// fragment's virtual texel (x, y) of its mip (the framebuffer is the mip, R_m × R_m) is
// translated through the page table — entry table_offset + (y >> 7)·side + (x >> 7) of its
// (map, mip) — to its physical pool slot, and the depth's float bits are atomicMax'ed into
// texel slot·128² + (y & 127)·128 + (x & 127), as the compute path does. Depth: the fixed-
// function interpolated z/w (reversed Z), clamped as raster.cpp clamps (§6 of spec/raster.md:
// [FLT_MIN, 1], NaN → FLT_MIN; every written depth positive, so the largest bits are the
// largest depth). A page without a slot is not written (the scissor makes this unreachable).
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_GOOGLE_include_directive : require
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shader_records.h"

layout(std430, binding = kRasterBindShadowPages) readonly buffer ShadowPages { GpuShadowPage shadow_pages[]; };
layout(std430, binding = kRasterBindShadowPool) buffer ShadowPool { uint32_t shadow_pool[]; };
layout(std430, binding = kHwShadowBindPageTable) readonly buffer ShadowTable { uint32_t shadow_table[]; };

layout(location = 0) flat in uint32_t page_index;

const float kMinWrittenDepth = 1.17549435e-38;  // FLT_MIN
const uint32_t kNoShadowSlot = 0xFFFFFFFFu;      // virtual_shadow.h
const uint32_t kPageShift = 7u;                  // 128 = kGpuShadowPageTexels texels per page side
const uint32_t kPageMask = kGpuShadowPageTexels - 1u;

void main() {
  float z = gl_FragCoord.z;
  if (!(z >= kMinWrittenDepth)) z = kMinWrittenDepth;
  if (z > 1.0) z = 1.0;
  const GpuShadowPage page = shadow_pages[page_index];
  const uint32_t x = uint32_t(gl_FragCoord.x), y = uint32_t(gl_FragCoord.y);
  const uint32_t slot = shadow_table[page.table_offset + (y >> kPageShift) * page.table_side + (x >> kPageShift)];
  if (slot == kNoShadowSlot) return;
  const uint32_t texel = (y & kPageMask) * kGpuShadowPageTexels + (x & kPageMask);
  atomicMax(shadow_pool[slot * kGpuShadowPageTexels * kGpuShadowPageTexels + texel], floatBitsToUint(z));
}
