#version 460
// Instance culling (cull.cpp cull_instances): list_in[kListHeaderWords..] are the candidate
// instances; each sets its bit in the instance-visible or instance-occluded set.
#include "cull_common.glsl"

layout(local_size_x = VGEO_CULL_GROUP_SIZE) in;

void main() {
  uint n = list_in[0];
  uint k = gl_GlobalInvocationID.x;
  if (k >= n) return;
  uint i = list_in[kListHeaderWords + k];
  atomicAdd(counters[kCounterInstancesIn], uint64_t(1));
  GpuCullInstance iv = instances[i];
  GpuCullMesh mesh = meshes[iv.mesh];
  if (mesh.node_count == 0u) return;
  GpuSphere b = nodes[mesh.first_node].bounds;
  if ((params.flags & kGpuCullFrustum) != 0u && sphere_outside_frustum(culling_sphere(iv, b), params.view)) return;
  if (occluded(i, b)) {
    atomicAdd(counters[kCounterInstancesOccluded], uint64_t(1));
    set_bit(params.instance_occluded_bits, i);
    return;
  }
  atomicAdd(counters[kCounterInstancesOut], uint64_t(1));
  set_bit(params.instance_visible_bits, i);
}
