#pragma once
// Instance culling and hierarchical LOD + cluster culling (Nanite deep dive, "Hierarchical
// culling", "Persistent threads", "Two-pass occlusion culling"). Normative: spec/scene.md
// §Frame pipeline.
//
// Per instance, the mesh's BVH8 (ClusterDag::bvh_nodes) is traversed by a fixed set of
// worker threads sharing two multi-producer multi-consumer queues: a node queue (BVH nodes)
// and a cluster queue (leaf groups whose clusters must be tested). A node passes when its
// bounds intersect the frustum, it is not occluded, and its LOD bound can still hold a
// cluster that is not fine enough yet: projected_error(lod_bounds, max_parent_error) > τ.
// Each cluster is drawn iff lod_selects(...) && in frustum && not occluded.
// Subtree bounds are inflated (view.h) so the hierarchy never prunes a cluster the flat test
// would select: traversal with culling off == the flat LOD test of every cluster, exactly.
// Outputs are sorted into canonical (instance, cluster) order: identical for any thread count.
#include <cstdint>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/cull/hzb.h"
#include "vgeo/cull/view.h"
#include "vgeo/stream/stream.h"

namespace vgeo {

// A placed mesh with a double-precision transform (far-away instances; spec/invariants.md).
struct CullInstance {
  uint32_t mesh = 0;
  Mat4d object_to_world;
};

// Per-instance view-dependent constants.
struct InstanceView {
  Mat4d object_to_view;
  double scale = 1;  // max_axis_scale(object_to_world): radii and errors are scaled by it
};
std::vector<InstanceView> make_instance_views(const std::vector<CullInstance>& instances,
                                              const ViewParams& view);

struct VisibleCluster {
  uint32_t instance = 0, cluster = 0;
  friend bool operator==(const VisibleCluster&, const VisibleCluster&) = default;
  friend auto operator<=>(const VisibleCluster&, const VisibleCluster&) = default;
};

// A postponed work item (occluded in pass 1, retested in pass 2).
struct CullItem {
  uint32_t instance = 0;
  uint32_t index = 0;  // BVH node index, group index or cluster index by kind
  enum Kind : uint32_t { kNode = 0, kGroup = 1, kCluster = 2 } kind = kNode;
  friend bool operator==(const CullItem&, const CullItem&) = default;
  friend auto operator<=>(const CullItem&, const CullItem&) = default;
};

// Occlusion is tested against `hzb` with spheres placed by `occlusion_view` +
// `occlusion_instances` (the previous frame's in pass 1, the current frame's in pass 2).
struct OcclusionInput {
  const Hzb* hzb = nullptr;
  const ViewParams* view = nullptr;
  const std::vector<InstanceView>* instances = nullptr;
  HzbMipPolicy policy = HzbMipPolicy::k4x4;
};

struct CullOptions {
  float threshold_px = 1.0f;     // τ
  bool frustum = true;           // false: LOD only (the per-frame cut)
  OcclusionInput occlusion;      // hzb == nullptr: no occlusion test
  // Streaming residency (spec/stream.md §Cut), indexed by mesh: usable_groups[m][g] != 0 iff
  // group g of mesh m is usable; an empty vector = every group of that mesh usable. null
  // (no streaming): the cluster test is exactly lod_selects, the path without residency.
  // When set, a cluster is drawn iff usable(g) ∧ proj(parent) > τ ∧ (proj(lod) ≤ τ ∨
  // ¬usable(generating group)), and every cluster of the ideal cut (lod_selects) that passes
  // the frustum test emits a GroupRequest (before occlusion) into CullResult::requests.
  const std::vector<std::vector<uint8_t>>* usable_groups = nullptr;
};

struct CullCounters {
  uint64_t instances_in = 0, instances_out = 0, instances_occluded = 0;
  uint64_t nodes_visited = 0, nodes_occluded = 0;
  uint64_t groups_visited = 0, groups_occluded = 0;
  uint64_t cluster_candidates = 0, clusters_selected_lod = 0, clusters_frustum_culled = 0,
           clusters_occluded = 0, clusters_visible = 0;
  // Streaming only: ideal-cut clusters passing the frustum test, and those of them whose
  // group is not usable (drawn coarser this frame).
  uint64_t clusters_ideal = 0, clusters_coarser = 0;
  void add(const CullCounters& o);
};

struct CullResult {
  std::vector<VisibleCluster> visible;  // sorted
  std::vector<CullItem> occluded;       // sorted; retest these in pass 2
  std::vector<GroupRequest> requests;   // streaming only: one per ideal in-frustum cluster, sorted by (mesh, group)
  CullCounters counters;
};

// Instance culling: frustum (current view) then occlusion. `candidates` are instance
// indices; `visible`/`occluded` receive sorted subsets.
void cull_instances(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                    const std::vector<InstanceView>& instance_views, const std::vector<uint32_t>& candidates,
                    const ViewParams& view, const CullOptions& options, std::vector<uint32_t>* visible,
                    std::vector<uint32_t>* occluded, CullCounters* counters);

// Persistent-thread traversal from `seeds` (BVH roots of visible instances, or postponed
// items). LOD and frustum use `view` + `instance_views`.
void cull_clusters(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                   const std::vector<InstanceView>& instance_views, const std::vector<CullItem>& seeds, const ViewParams& view, const CullOptions& options,
                   ThreadPool& pool, CullResult* out);

// The per-frame LOD cut: every (instance, cluster) selected by the LOD test alone, before
// frustum and occlusion culling (hierarchical traversal with culling off). Sorted.
// With `usable_groups` (CullOptions): the resident cut of spec/stream.md §Cut.
std::vector<VisibleCluster> select_cut(const std::vector<ClusterDag>& meshes,
                                       const std::vector<CullInstance>& instances,
                                       const ViewParams& view, float threshold_px, ThreadPool& pool,
                                       const std::vector<std::vector<uint8_t>>* usable_groups = nullptr);

// True when the BVH reachable from node 0 is a tree (no node reached twice, so no cycle):
// traversal of an untrusted DAG terminates. Index ranges are dag_io's job.
bool bvh_is_tree(const ClusterDag& dag);

// The cut's cluster indices of one instance (ascending): the input of lib/vgeo/verify's check_cut.
std::vector<uint32_t> cut_of_instance(const std::vector<VisibleCluster>& cut, uint32_t instance);

// Reference: the flat test of every cluster of every instance (tests compare against it).
std::vector<VisibleCluster> select_flat(const std::vector<ClusterDag>& meshes,
                                        const std::vector<CullInstance>& instances,
                                        const ViewParams& view, float threshold_px, bool frustum);

}  // namespace vgeo
