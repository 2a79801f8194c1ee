#ifndef VGEO_CORE_CULL_SHARED_H
#define VGEO_CORE_CULL_SHARED_H
// The constants of the CPU cull (lib/vgeo/cull) and the records the GPU cull passes (shaders/cull_*.comp, lib/vgeo/gpu/gpu_cull.cpp)
// share between C++ and GLSL, written once (common subset: shared_glsl.h). Every member is
// 4 or 8 bytes and every struct is ordered so std430 equals the C++ layout (no implicit
// padding on either side); lib/vgeo/gpu/gpu_cull.cpp static_asserts that GpuCluster,
// GpuGroup and GpuBvhNode are byte-for-byte DagCluster, DagGroup and BvhNode, so the DAG's
// arrays are uploaded as they are. Normative: spec/raster.md §12.
#include "vgeo/core/shared_glsl.h"

#ifdef __cplusplus
namespace vgeo {
#endif

// ---- the CPU cull's constants (lib/vgeo/cull/view.h, hzb.cpp use these same definitions) ----
// 2^-16 relative + 2^-20 of the centre's distance (view.h: inflate_for_subtree_test).
VGEO_CONSTANT double kConservativeRelativeSlack = 1.0 / 65536.0;
VGEO_CONSTANT double kConservativeCentreSlack = 1.0 / 1048576.0;
// HZB relative depth margin (hzb.cpp: hzb_occludes).
VGEO_CONSTANT double kHzbDepthMargin = 1.0 / 16384.0;
// HzbMipPolicy values (hzb.h).
VGEO_CONSTANT uint32_t kHzbPolicy4x4 = 0u;
VGEO_CONSTANT uint32_t kHzbPolicy2x2 = 1u;
VGEO_CONSTANT uint32_t kHzbPolicyFinest = 2u;
// Mip levels an HZB may have: 1 + log2(16384) (kMaxRasterViewport) rounded up.
VGEO_CONSTANT uint32_t kGpuHzbMaxLevels = 16u;

// llvmpipe (Mesa 22.3, gallivm lp_exec_endloop) ends every loop of a shader invocation
// vector once LP_MAX_TGSI_LOOP_ITERATIONS loop back edges have run since the shader began
// (one counter per invocation, set at entry, never reset, shared by every loop). Every cull
// shader is bounded below this (spec/raster.md §12): the host checks the bound per dispatch;
// the compute rasterizer checks its own in the shader and the host fails on a flag (§13.5).
VGEO_CONSTANT uint32_t kGpuLoopBudget = 65535u;

// ---- DAG records (== DagCluster, DagGroup, BvhNode) ----
struct GpuSphere {
  float x, y, z, radius;
};
struct GpuCluster {
  uint32_t vertex_offset, vertex_count, triangle_offset, triangle_count;
  uint32_t group, generating_group, level, material_offset;
  GpuSphere bounds, lod_bounds, parent_bounds;
  float lod_error, parent_error;
  uint32_t pad0, pad1;
};
struct GpuGroup {
  uint32_t first_cluster, cluster_count, first_generated, generated_count;
  uint32_t level, flags, pad0, pad1;
  GpuSphere bounds, parent_bounds;
  float parent_error;
  uint32_t pad2, pad3, pad4;
};
VGEO_CONSTANT uint32_t kGpuBvhMaxChildren = 8u;
VGEO_CONSTANT uint32_t kGpuNone = 0xFFFFFFFFu;
struct GpuBvhNode {
  GpuSphere bounds, lod_bounds;
  float max_parent_error;
  uint32_t child_count, group_mask, pad0;
  uint32_t children[8];  // kGpuBvhMaxChildren
};

// Where one mesh's records start in the concatenated arrays (indices in a mesh's records
// stay mesh-local, as in ClusterDag).
// `stream_base`: where the mesh's streaming words start in the stream buffer
// (cull_common.glsl binding 13, spec/raster.md §12 "Streaming"): word stream_base is 1 when
// the mesh streams this frame (CullOptions::usable_groups non-empty for it), then
// group_count usable flags (resident_lod_test's `usable`), then group_count request words
// (the float bits of the highest priority requested for that group this pass, 0 = none).
struct GpuCullMesh {
  uint32_t first_cluster, cluster_count, first_group, group_count;
  uint32_t first_node, node_count, stream_base, pad0;
};

// One instance in one view (== InstanceView + its mesh): the double object-to-view matrix
// (column-major, m[col*4+row], as Mat4d) and max_axis_scale. `cluster_key_base` and
// `item_key_base` place the instance's clusters / work items in the output bit sets
// (canonical order, see below).
struct GpuCullInstance {
  double object_to_view[16];
  double scale;
  uint32_t mesh, cluster_key_base, item_key_base, pad0;
};

// The parts of ViewParams the tests read (frustum, LOD, screen rectangles).
struct GpuCullView {
  double tan_half_x, tan_half_y, z_near;
  uint32_t width, height;
  float pixels_per_unit_at_1;  // LodView::pixels_per_unit_at_1
  float lod_z_near;            // LodView::z_near = float(z_near)
  uint32_t pad0, pad1;
};

VGEO_CONSTANT uint32_t kGpuCullFrustum = 1u;    // CullOptions::frustum
VGEO_CONSTANT uint32_t kGpuCullOcclusion = 2u;  // CullOptions::occlusion.hzb != null

// Bit-set regions (word offsets into the bits buffer) and the HZB's mip table.
struct GpuCullParams {
  GpuCullView view;            // frustum + LOD (the current frame)
  GpuCullView occlusion_view;  // the view the HZB was rendered with
  float threshold_px;
  uint32_t flags, hzb_policy, hzb_levels;
  uint32_t hzb_width, hzb_height, instance_count, queue_capacity;
  uint32_t visible_bits, occluded_bits, instance_visible_bits, instance_occluded_bits;
  uint32_t visible_words, occluded_words, instance_words;
  uint32_t occlusion_previous;  // host only: occlusion reads the previous frame's HZB and instances
  uint32_t hzb_mip_offset[16], hzb_mip_width[16], hzb_mip_height[16];  // kGpuHzbMaxLevels
};

// The counters, in CullCounters' member order (uint64 each).
VGEO_CONSTANT uint32_t kCounterInstancesIn = 0u;
VGEO_CONSTANT uint32_t kCounterInstancesOut = 1u;
VGEO_CONSTANT uint32_t kCounterInstancesOccluded = 2u;
VGEO_CONSTANT uint32_t kCounterNodesVisited = 3u;
VGEO_CONSTANT uint32_t kCounterNodesOccluded = 4u;
VGEO_CONSTANT uint32_t kCounterGroupsVisited = 5u;
VGEO_CONSTANT uint32_t kCounterGroupsOccluded = 6u;
VGEO_CONSTANT uint32_t kCounterClusterCandidates = 7u;
VGEO_CONSTANT uint32_t kCounterClustersSelectedLod = 8u;
VGEO_CONSTANT uint32_t kCounterClustersFrustumCulled = 9u;
VGEO_CONSTANT uint32_t kCounterClustersOccluded = 10u;
VGEO_CONSTANT uint32_t kCounterClustersVisible = 11u;
VGEO_CONSTANT uint32_t kCounterClustersIdeal = 12u;
VGEO_CONSTANT uint32_t kCounterClustersCoarser = 13u;
VGEO_CONSTANT uint32_t kCounterCount = 14u;

// Work items (CullItem) in the traversal queue: one 64-bit word written and read with one
// atomic, so a slot is either empty (0) or complete:
//   bits 63..32 instance, bits 31..30 kind + 1 (never 0), bits 29..0 index.
VGEO_CONSTANT uint32_t kItemNode = 0u, kItemGroup = 1u, kItemCluster = 2u;
VGEO_CONSTANT uint32_t kItemKinds = 3u;
VGEO_CONSTANT uint32_t kItemIndexBits = 30u;
VGEO_CONSTANT uint32_t kItemIndexMask = (1u << kItemIndexBits) - 1u;
// Bit 63 marks a cluster item seeded from pass 1's occluded list (cull.cpp test_cluster's
// from_group == false: its stream request was emitted in pass 1); instances stay < 2^31.
VGEO_CONSTANT uint32_t kItemSeededBit = 0x80000000u;  // in the instance word (bits 63..32)
VGEO_CONSTANT uint32_t kItemInstanceMask = 0x7FFFFFFFu;
VGEO_FUNCTION uint64_t pack_cull_item(uint32_t instance, uint32_t index, uint32_t kind) {
  return (uint64_t(instance) << 32) | (uint64_t(kind + 1u) << kItemIndexBits) | uint64_t(index);
}

// Queue header (then the slots): `pending` counts items pushed and not finished (the
// persistent traversal ends at 0); [level_begin, level_end) is the level being processed
// by the level-by-level traversal and `dispatch` its indirect arguments.
struct GpuQueueHeader {
  uint32_t read_head, write_head, pending, level_begin;
  uint32_t level_end, dispatch_x, dispatch_y, dispatch_z;
};

// Canonical output order: a set bit per selected thing, compacted in key order.
//   cluster key  = cluster_key_base(instance) + cluster          → (instance, cluster) order
//   item key     = item_key_base(instance) + 3 * index + kind    → CullItem's (instance, index, kind) order
// so the GPU's append order never reaches an output.
VGEO_CONSTANT uint32_t kCompactInstances = 0u;  // record: instance
VGEO_CONSTANT uint32_t kCompactClusters = 1u;   // record: instance, cluster (VisibleCluster)
VGEO_CONSTANT uint32_t kCompactItems = 2u;      // record: instance, index, kind (CullItem)
// A compacted list: `count` then the records from word kListHeaderWords on.
VGEO_CONSTANT uint32_t kListHeaderWords = 4u;

// Push constants of every cull dispatch: `mode` selects a kCompact* record or a seed source,
// [word_begin, word_begin + word_count) the bit-set words to compact; `append` != 0: the
// records go after those already in the list (pass 2's visible clusters follow pass 1's,
// as in frame.cpp, so a visible-cluster index means the same on both backends).
// `iterations`: the persistent traversal's loop budget per invocation for this dispatch
// (spec/raster.md §12, "Bounded work per invocation").
struct GpuCullPush {
  uint32_t mode, word_begin, word_count, append, iterations;
};
VGEO_CONSTANT uint32_t kSeedInstances = 0u;  // list_in holds instance indices: seed BVH roots
VGEO_CONSTANT uint32_t kSeedItems = 1u;      // list_in holds CullItems (pass 1's occluded)

// Workgroup sizes (lavapipe: 8-wide subgroups; 64 = 8 subgroups per workgroup). Macros so
// that `layout(local_size_x = ...)` gets a literal (a constant would need maintenance4's
// LocalSizeId).
#define VGEO_CULL_GROUP_SIZE 64
#define VGEO_COMPACT_GROUP_SIZE 1024  // the most words per invocation: cost bound, gpu_cull.cpp
#define VGEO_HZB_GROUP_SIZE 64
#define VGEO_PERSISTENT_GROUP_SIZE 8  // one lavapipe subgroup (cull_traverse_persistent.comp)
VGEO_CONSTANT uint32_t kCullGroupSize = VGEO_CULL_GROUP_SIZE;
VGEO_CONSTANT uint32_t kCompactGroupSize = VGEO_COMPACT_GROUP_SIZE;
VGEO_CONSTANT uint32_t kHzbGroupSize = VGEO_HZB_GROUP_SIZE;

#ifdef __cplusplus
}  // namespace vgeo
#endif
#endif
