#version 460
// Hardware raster path, vertex stage (spec/raster.md §13): one non-indexed draw per visible
// cluster (firstInstance = visible-cluster index), three vertices per triangle. Decodes the
// cluster's memory form through the same reader as the compute rasterizer
// (shaders/memory_page.glsl) and transforms in double as raster.cpp does
// (((m0·x + m4·y) + m8·z) + m12 from the float matrix), then rounds to float for the
// fixed-function pipeline. Screen y points down in both conventions, so clip y is negated
// (our NDC y is up, Vulkan's is down).
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_GOOGLE_include_directive : require
#include "vgeo/core/vis_key.h"
#include "vgeo/gpu/shader_records.h"

#include "geometry.glsl"
layout(push_constant) uniform Push { GpuRasterParams params; };

#define VGEO_PAGE_WORD(i) page_words[i]
#include "memory_page.glsl"

layout(location = 0) flat out uint32_t id_bits;

void main() {
  uint32_t visible_index = uint32_t(gl_InstanceIndex);
  GpuVisibleCluster vc = visible[visible_index];
  GpuInstance inst = instances[vc.instance];
  GpuMesh mesh = meshes[inst.mesh];
  GpuClusterLocation loc = locations[mesh.first_location + vc.cluster];
  MemoryCluster c = memory_cluster(loc.page_word, loc.cluster_in_page, mesh.channel_count);
  uint32_t tri = uint32_t(gl_VertexIndex) / 3u;
  uint32_t corner = uint32_t(gl_VertexIndex) % 3u;
  uvec3 idx = memory_triangle(c, tri);
  uint32_t v = corner == 0u ? idx.x : (corner == 1u ? idx.y : idx.z);
  double p[3];
  for (uint32_t k = 0u; k < 3u; ++k) p[k] = double(dequantize_position(memory_vertex_channel(c, v, k), mesh.position_step_log2));
  float cc[4];
  for (int r = 0; r < 4; ++r) {
    precise double s = ((double(inst.object_to_clip[r]) * p[0] + double(inst.object_to_clip[4 + r]) * p[1]) +
                        double(inst.object_to_clip[8 + r]) * p[2]) + double(inst.object_to_clip[12 + r]);
    cc[r] = float(s);
  }
  gl_Position = vec4(cc[0], -cc[1], cc[2], cc[3]);
  id_bits = (visible_index << kVisTriangleBits) | tri;
}
