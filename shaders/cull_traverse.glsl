// One work item of the hierarchical traversal (cull.cpp cull_clusters: `process` and
// `test_cluster`), shared by the persistent-threads and the level-by-level traversal.
// Decisions are recorded as bits (canonical order, cull_shared.h); counters are summed per
// workgroup in shared memory and added to the counter buffer once at the end. Every item
// costs at most one HZB test and one push loop (≤ kBvhMaxChildren or a group's cluster
// count): the loop bound that gpu_cull.cpp checks against kGpuLoopBudget.
#include "cull_common.glsl"

shared uint s_counters[kCounterCount];

// Both with the whole workgroup (barriers).
void clear_counters() {
  if (gl_LocalInvocationIndex == 0u)
    for (uint i = 0u; i < kCounterCount; ++i) s_counters[i] = 0u;
  barrier();
}
void flush_counters() {
  barrier();
  if (gl_LocalInvocationIndex == 0u)
    for (uint i = 0u; i < kCounterCount; ++i)
      if (s_counters[i] != 0u) atomicAdd(counters[i], uint64_t(s_counters[i]));
}
void count(uint counter) { atomicAdd(s_counters[counter], 1u); }

// cull.cpp cluster_lod_selects = lod_selects(...) of lod.h.
bool cluster_lod_selects(GpuCluster c, GpuCullInstance iv, GpuCullView v, float tau) {
  return projected_error(sphere_to_view(iv, sphere_of(c.parent_bounds)), error_to_view(c.parent_error, iv.scale), v) > tau &&
         projected_error(sphere_to_view(iv, sphere_of(c.lod_bounds)), error_to_view(c.lod_error, iv.scale), v) <= tau;
}

// cull.cpp subtree_may_select.
bool subtree_may_select(GpuSphere lod_bounds, float max_parent_error, GpuCullInstance iv, GpuCullView v, float tau) {
  Sphere s = culling_sphere(iv, lod_bounds);
  float e = inflate_error_for_subtree_test(error_to_view(max_parent_error, iv.scale));
  return projected_error(s, e, v) > tau;
}

uint item_key(uint instance, uint index, uint kind) {
  return instances[instance].item_key_base + index * kItemKinds + kind;
}

void test_cluster(uint instance, uint ci) {
  GpuCullInstance iv = instances[instance];
  GpuCluster c = clusters[meshes[iv.mesh].first_cluster + ci];
  count(kCounterClusterCandidates);
  if (!cluster_lod_selects(c, iv, params.view, params.threshold_px)) return;
  count(kCounterClustersSelectedLod);
  if ((params.flags & kGpuCullFrustum) != 0u && sphere_outside_frustum(culling_sphere(iv, c.bounds), params.view)) {
    count(kCounterClustersFrustumCulled);
    return;
  }
  if (occluded(instance, c.bounds)) {
    count(kCounterClustersOccluded);
    set_bit(params.occluded_bits, item_key(instance, ci, kItemCluster));
    return;
  }
  count(kCounterClustersVisible);
  set_bit(params.visible_bits, iv.cluster_key_base + ci);
}

// Appends `count` children of a node to the queue (one atomic for the slots). Returns the
// number pushed.
uint push_children(uint instance, GpuBvhNode node) {
  uint count = min(node.child_count, kGpuBvhMaxChildren);
  if (count == 0u) return 0u;
  uint first = atomicAdd(queue.write_head, count);
  for (uint k = 0u; k < count; ++k) {
    uint kind = ((node.group_mask >> k) & 1u) != 0u ? kItemGroup : kItemNode;
    atomicExchange(slots[first + k], pack_cull_item(instance, node.children[k], kind));
  }
  return count;
}

// Appends a group's clusters to the queue as cluster items (one atomic for the slots), so
// that an invocation makes at most one HZB test per item (bounded work: spec/raster.md §12).
// cull.cpp tests them inside the group's step; the decisions and counters are the same.
uint push_clusters(uint instance, GpuGroup g) {
  if (g.cluster_count == 0u) return 0u;
  uint first = atomicAdd(queue.write_head, g.cluster_count);
  for (uint k = 0u; k < g.cluster_count; ++k)
    atomicExchange(slots[first + k], pack_cull_item(instance, g.first_cluster + k, kItemCluster));
  return g.cluster_count;
}

// Processes one packed item; returns the number of children pushed.
uint process_item(uint64_t packed) {
  uint instance = uint(packed >> 32);
  uint kind = (uint(packed) >> kItemIndexBits) - 1u;
  uint index = uint(packed) & kItemIndexMask;
  GpuCullInstance iv = instances[instance];
  GpuCullMesh mesh = meshes[iv.mesh];
  bool frustum = (params.flags & kGpuCullFrustum) != 0u;
  float tau = params.threshold_px;
  if (kind == kItemNode) {
    GpuBvhNode node = nodes[mesh.first_node + index];
    count(kCounterNodesVisited);
    if (frustum && sphere_outside_frustum(culling_sphere(iv, node.bounds), params.view)) return 0u;
    if (!subtree_may_select(node.lod_bounds, node.max_parent_error, iv, params.view, tau)) return 0u;
    if (occluded(instance, node.bounds)) {
      count(kCounterNodesOccluded);
      set_bit(params.occluded_bits, item_key(instance, index, kItemNode));
      return 0u;
    }
    return push_children(instance, node);
  }
  if (kind == kItemGroup) {
    GpuGroup g = groups[mesh.first_group + index];
    count(kCounterGroupsVisited);
    if (frustum && sphere_outside_frustum(culling_sphere(iv, g.bounds), params.view)) return 0u;
    if (!subtree_may_select(g.parent_bounds, g.parent_error, iv, params.view, tau)) return 0u;
    if (occluded(instance, g.bounds)) {
      count(kCounterGroupsOccluded);
      set_bit(params.occluded_bits, item_key(instance, index, kItemGroup));
      return 0u;
    }
    return push_clusters(instance, g);
  }
  test_cluster(instance, index);
  return 0u;
}
