#version 460
// Hardware raster path of the virtual shadow pages, vertex stage (spec/shadow.md §8): one
// non-indexed draw per element (cluster, page), firstInstance = the element's index, three
// vertices per triangle, drawn in its page's mip viewport (R_m × R_m) and scissored to the
// page. The vertex work is hw_raster.vert's (memory-form reader, double transform rounded to
// float, clip y negated); the instance is the element's (view, instance) GpuInstance.
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_GOOGLE_include_directive : require
#include "vgeo/core/vis_key.h"
#include "vgeo/gpu/shader_records.h"

#include "geometry.glsl"

#define VGEO_PAGE_WORD(i) page_words[i]
#include "memory_page.glsl"

layout(std430, binding = kRasterBindShadowElementPage) readonly buffer ShadowElementPage { uint32_t shadow_element_page[]; };

layout(location = 0) flat out uint32_t page_index;

void main() {
  uint32_t element = uint32_t(gl_InstanceIndex);
  GpuVisibleCluster vc = visible[element];
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
  page_index = shadow_element_page[element];
}
