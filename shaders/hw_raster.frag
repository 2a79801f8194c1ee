#version 460
// Hardware raster path, fragment stage (spec/raster.md §13): the same 64-bit key and
// atomicMax into the storage-buffer visibility buffer as shaders/raster.comp (layout:
// core/vis_key.h). Depth is the fixed-function interpolated z/w (reversed Z), clamped as
// raster.cpp clamps (§6: [FLT_MIN, 1], NaN → FLT_MIN). No attachments: this is the only output.
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_GOOGLE_include_directive : require
#include "vgeo/core/vis_key.h"
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shader_records.h"

layout(std430, binding = kGeomBindVis) buffer Vis { uint64_t vis[]; };
layout(std430, binding = kRasterBindCounters) buffer Counters { uint64_t pixels_written; };
layout(push_constant) uniform Push { GpuRasterParams params; };

layout(location = 0) flat in uint32_t id_bits;

const float kMinWrittenDepth = 1.17549435e-38;  // FLT_MIN

void main() {
  float z = gl_FragCoord.z;
  if (!(z >= kMinWrittenDepth)) z = kMinWrittenDepth;
  if (z > 1.0) z = 1.0;
  uint32_t px = uint32_t(gl_FragCoord.x), py = uint32_t(gl_FragCoord.y);
  atomicMax(vis[py * params.width + px], pack_vis_key_bits(floatBitsToUint(z), 0u, 0u) | uint64_t(id_bits));
  atomicAdd(pixels_written, uint64_t(1));
}
