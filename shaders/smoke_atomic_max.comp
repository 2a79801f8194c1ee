#version 460
// Infrastructure smoke test (tests/gpu): every invocation folds one 64-bit value into
// slot (i % slot_count) with atomicMax — the operation the visibility buffer is built on.
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_GOOGLE_include_directive : require
#include "vgeo/core/vis_key.h"
#include "vgeo/gpu/shader_bindings.h"

layout(local_size_x = 64) in;
layout(std430, binding = kSmokeBindValues) readonly buffer Values { uint64_t values[]; };
layout(std430, binding = kSmokeBindSlots) buffer Slots { uint64_t slots[]; };
layout(push_constant) uniform Push { uint32_t value_count; uint32_t slot_count; };

void main() {
  uint32_t i = gl_GlobalInvocationID.x;
  if (i >= value_count) return;
  uint64_t v = values[i];
  // Round-trip through the shared key helpers: the same bits must come back.
  uint64_t key = pack_vis_key_bits(vis_key_depth_bits(v), vis_key_cluster(v), vis_key_triangle(v));
  atomicMax(slots[i % slot_count], key);
}
