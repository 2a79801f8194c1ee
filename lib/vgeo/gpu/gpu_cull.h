#pragma once
// The frame's cull passes on the GPU (normative: spec/raster.md §12):
// instance cull, hierarchical BVH traversal with the LOD test and cluster frustum/HZB cull
// (two variants: persistent threads, level by level), HZB build from the visibility buffer,
// and pass 2's retest. Each pass is the GLSL of the same decision in lib/vgeo/cull, so every
// output equals the CPU reference's (cull_instances, cull_clusters, build_hzb) exactly:
// lists in the same canonical order, the same counters. Outputs are compacted from bit sets,
// so the GPU's append order never reaches them.
//
// Use: upload the meshes once (GpuCullMeshes), make a GpuCullFrame per view size, write
// the view (write_cull_view) and record passes (cmd_cull_*, cmd_build_hzb) between
// begin_commands and submit_and_wait; read results with read_* after the submit.
#include <cstdint>
#include <vector>

#include "vgeo/core/cull_shared.h"
#include "vgeo/cull/cull.h"
#include "vgeo/cull/hzb.h"
#include "vgeo/gpu/context.h"

namespace vgeo {

enum class GpuTraversal : uint8_t {
  kPersistent = 0,  // Nanite's persistent threads on one MPMC queue (needs resident workgroups)
  kLevel = 1,       // one indirect dispatch per BVH level (no forward-progress assumption)
};
// The default (measured by `vgeo bench` gpu_cull, spec/raster.md §12).
inline constexpr GpuTraversal kDefaultGpuTraversal = GpuTraversal::kLevel;

struct GpuCullPipelines {
  ComputePipeline instances, seed, traverse_persistent, traverse_level, advance, compact, hzb;
};
GpuCullPipelines create_cull_pipelines(GpuContext& gpu);

// The scene's DAG records, concatenated (DagCluster/DagGroup/BvhNode uploaded as they are).
struct GpuCullMeshes {
  GpuBuffer meshes, clusters, groups, nodes;
  GpuBuffer stream;  // per mesh at GpuCullMesh::stream_base: streams flag, usable flags, requests
  std::vector<GpuCullMesh> table;
  uint32_t levels = 0;  // dispatches the level-by-level traversal needs: deepest BVH node + 3
  uint32_t max_group_clusters = 0;  // a group's push loop (the per-item loop bound)
};
GpuCullMeshes upload_cull_meshes(GpuContext& gpu, const std::vector<ClusterDag>& meshes);

// Streaming (CullOptions::usable_groups, spec/stream.md §Cut): the usable groups per mesh
// for the next cull passes (an empty vector, or no entry: the mesh does not stream and its
// clusters take the lod_selects test).
void write_cull_usable(GpuCullMeshes& meshes, const std::vector<std::vector<uint8_t>>& usable);
// After a cluster cull pass (submit_and_wait): the pass's requests, one per (mesh, group)
// with the highest priority, sorted by (mesh, group) as cull_clusters' CullResult::requests;
// clears them for the next pass.
std::vector<GroupRequest> take_cull_requests(GpuCullMeshes& meshes);

// Per-scene key layout of the output bit sets (gpu/cull_shared.h): fixed by the scene.
struct GpuCullLayout {
  std::vector<uint32_t> cluster_key_base, item_key_base;  // per instance
  uint32_t visible_words = 0, occluded_words = 0, instance_words = 0, queue_capacity = 0;
};
GpuCullLayout make_cull_layout(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances);

// HZB mip table (hzb.cpp's sizes: halve rounding up until 1x1) and the words of all mips.
struct GpuHzbLayout {
  uint32_t width = 0, height = 0, levels = 0, words = 0;
  uint32_t offset[kGpuHzbMaxLevels] = {}, mip_width[kGpuHzbMaxLevels] = {}, mip_height[kGpuHzbMaxLevels] = {};
};
GpuHzbLayout make_hzb_layout(uint32_t width, uint32_t height);

// One view's working set. `params[k]` are the parameters of cull pass k (0: pass 1, against
// the previous frame's HZB; 1: pass 2, against this frame's); lists hold kListHeaderWords
// then records.
struct GpuCullFrame {
  GpuCullLayout layout;
  GpuHzbLayout hzb_layout;
  GpuBuffer params[2];
  GpuBuffer instances, previous_instances;  // GpuCullInstance per instance: this view, the HZB's view
  GpuBuffer hzb, previous_hzb;              // all mips, float bits
  GpuBuffer queue, bits;
  GpuBuffer candidates;                     // instance list (all instances)
  GpuBuffer visible_instances, occluded_instances, post_instances;  // instance lists
  GpuBuffer visible[2], occluded_items;     // VisibleCluster lists (pass 1 / pass 2, or both appended); pass 1's CullItems
  GpuBuffer counters[4];                    // CullCounters of instance_cull, cluster_cull, *_post
  uint64_t persistent_dispatches = 0;       // of the persistent traversal since creation (tests, bench)
};
GpuCullFrame create_cull_frame(GpuContext& gpu, const std::vector<ClusterDag>& meshes,
                               const std::vector<CullInstance>& instances, uint32_t width, uint32_t height);

// Pass k's decisions: LOD + frustum from `view`; occlusion against `occlusion` (null: none).
struct GpuOcclusion {
  const ViewParams* view = nullptr;        // the view the HZB was rendered with
  bool previous = true;                    // true: frame.previous_hzb/previous_instances; false: this frame's
  HzbMipPolicy policy = HzbMipPolicy::k4x4;
};
void write_cull_params(GpuCullFrame& frame, uint32_t pass, const ViewParams& view, float threshold_px, bool frustum,
                       const GpuOcclusion* occlusion);
// InstanceView + mesh → GpuCullInstance, into frame.instances (or previous_instances).
void write_cull_instances(GpuCullFrame& frame, const std::vector<CullInstance>& instances,
                          const std::vector<InstanceView>& views, bool previous);
// The CPU reference's HZB uploaded as the previous frame's (tests; hzb sized as the frame).
void write_previous_hzb(GpuCullFrame& frame, const Hzb& hzb);

// Instance cull of every instance (frame.candidates) with pass `pass`'s parameters, or of
// `input` (pass 2: pass 1's occluded instances). Outputs: sorted instance lists.
void cmd_cull_instances(GpuRecorder& rec, const GpuCullPipelines& p, const GpuCullMeshes& m, GpuCullFrame& f,
                        uint32_t pass, const GpuBuffer& input, GpuBuffer& visible_out, GpuBuffer* occluded_out,
                        GpuBuffer& counters);
// Traversal from seeds: BVH roots of `seed_instances` plus (optional) `seed_items`.
// Outputs: the sorted visible list (VisibleCluster records; `append_visible`: after the
// records already there, as pass 2 follows pass 1) and, if `occluded_out`, the sorted
// occluded items (CullItem records). A list's records start at word kListHeaderWords, i.e.
// VisibleCluster record kListHeaderWords / 2 (a raster pass binds the list and starts there).
void cmd_cull_clusters(GpuRecorder& rec, const GpuCullPipelines& p, const GpuCullMeshes& m, GpuCullFrame& f,
                       uint32_t pass, GpuTraversal traversal, const GpuBuffer& seed_instances,
                       const GpuBuffer* seed_items, GpuBuffer& visible_out, bool append_visible,
                       GpuBuffer* occluded_out, GpuBuffer& counters);
// HZB of `vis` (width*height uint64 keys) into `hzb_out` (frame.hzb or previous_hzb).
void cmd_build_hzb(GpuRecorder& rec, const GpuCullPipelines& p, GpuCullFrame& f, const GpuBuffer& vis,
                   GpuBuffer& hzb_out);

// After submit_and_wait.
std::vector<uint32_t> read_instance_list(const GpuBuffer& list);
std::vector<VisibleCluster> read_visible_list(const GpuBuffer& list);
std::vector<CullItem> read_item_list(const GpuBuffer& list);
CullCounters read_cull_counters(const GpuBuffer& counters);
Hzb read_hzb(const GpuCullFrame& frame, const GpuBuffer& hzb);

}  // namespace vgeo
