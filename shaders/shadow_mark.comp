#version 460
// Step shadow_mark on the device (spec/shadow.md §4; virtual_shadow.cpp mark_shadow_pages): for
// every covered pixel of the primary visibility buffer, its sample point and footprint, and for
// every shadowing light the page of the texel it needs marked (needed[entry] = 1; every writer
// writes 1, so the order does not matter). One invocation per pixel.
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_GOOGLE_include_directive : require
#include "vgeo/core/vis_key.h"
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shader_records.h"

layout(local_size_x = 64) in;  // kShadeGroupSize, as shade.comp

layout(std430, binding = kMarkBindVis) readonly buffer Vis { uint64_t vis[]; };
layout(std430, binding = kMarkBindLitFrame) readonly buffer LitFrame { GpuLitFrame lit; };
layout(std430, binding = kMarkBindLights) readonly buffer Lights { GpuShadeLight lights[]; };
layout(std430, binding = kMarkBindShadowMaps) readonly buffer ShadowMaps { GpuShadowMap shadow_maps[]; };
layout(std430, binding = kMarkBindNeeded) writeonly buffer Needed { uint32_t needed[]; };
layout(push_constant) uniform Push { GpuShadeParams params; };

#include "shadow_select.glsl"

void main() {
  const uint32_t p = gl_GlobalInvocationID.x;
  if (p >= params.width * params.height) return;
  const uint64_t key = vis[p];
  if (key == uint64_t(0)) return;
  const uint32_t x = p % params.width, y = p / params.width;
  double footprint;
  const dvec3 sp = shadow_sample_point(x, y, uintBitsToFloat(vis_key_depth_bits(key)), footprint);
  for (uint32_t l = 0u; l < lit.light_count; ++l) {
    ShadowTexel t;
    if (select_shadow_texel(l, sp, footprint, t)) needed[shadow_page_entry(t)] = 1u;
  }
}
