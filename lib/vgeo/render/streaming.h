#pragma once
// Streaming in the renderer (normative: spec/stream.md §Renderer): residency masks for the
// traversal and the geometry of drawn clusters read from resident memory-form pages.
//
// With streaming, RenderScene::meshes holds only the always-resident part of a streamed
// mesh (the page file's metadata DAG: bounds, errors, hierarchy; no vertex arrays), which
// is all the culling reads. The rasterizer and the shader read `FrameStreaming::geometry`
// instead: per scene mesh a ClusterDag whose `clusters` table mirrors the metadata and whose
// vertex/index arrays hold only the clusters drawn this frame, decoded from resident pages
// with lib/vgeo/format decode_cluster (the shared bitstream reader) and addressed through the
// mirrored clusters' vertex/triangle offsets. Resident geometry is therefore the page pool
// (≤ budget) plus this frame's drawn clusters. Meshes not from page files keep their full
// DAG, moved into `geometry`, with a metadata-only copy left in the scene.
#include <cstdint>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/cull/cull.h"
#include "vgeo/stream/stream.h"

namespace vgeo {

struct RenderScene;

struct FrameStreaming {
  Streamer* streamer = nullptr;
  std::vector<uint32_t> stream_mesh;       // per scene mesh: mesh in the streamer, kNone = in memory
  std::vector<uint32_t> material_offset;   // per scene mesh: added to decoded material ids
  std::vector<ClusterDag> geometry;        // per scene mesh: what raster and shade read
  // Per streamed scene mesh: each cluster's index inside its page; frame it was last bound.
  std::vector<std::vector<uint32_t>> cluster_in_page;
  std::vector<std::vector<uint64_t>> bound_frame;
  uint64_t frame = 0;
  std::vector<std::vector<uint8_t>> usable;  // this frame, per scene mesh (empty = all usable)
  std::vector<GroupRequest> requests;        // this frame, scene mesh ids mapped to the streamer's
  // The shadow views' requests of the previous frame's shadow_draw (scene mesh ids, priorities
  // from secondary_view_priority: below every primary request), handed to this frame's
  // stream_end with its primary requests (spec/shadow.md §9: shadow_draw runs after stream_end).
  std::vector<GroupRequest> shadow_requests;
  StreamFrameStats stats;                    // this frame
};

// Sets up `out` for `scene`: scene mesh m is streamed as the streamer's mesh stream_mesh[m]
// (its scene DAG must be that mesh's metadata DAG) or kept in memory (kNone).
void init_frame_streaming(RenderScene* scene, Streamer* streamer, const std::vector<uint32_t>& stream_mesh,
                          const std::vector<uint32_t>& material_offset, FrameStreaming* out);

// Frame start: installs completed reads and computes the usable masks.
void begin_streamed_frame(const RenderScene& scene, FrameStreaming* s);
// Recomputes the usable masks from the residency now (after stream_end evicted: what the
// shadow views may draw).
void refresh_usable_groups(const RenderScene& scene, FrameStreaming* s);
// Decodes the geometry of visible[first..] clusters of streamed meshes that are not bound yet
// this frame (each from its resident page) into s->geometry. Throws FORMAT_INCONSISTENT if a
// page's cluster disagrees with the metadata.
void bind_streamed_geometry(FrameStreaming* s, const RenderScene& scene, const std::vector<VisibleCluster>& visible,
                            size_t first, ThreadPool& pool);
// Frame end: adds the traversal's requests and counters, issues reads, evicts.
void end_streamed_frame(FrameStreaming* s, const std::vector<GroupRequest>& requests, uint64_t clusters_coarser,
                        uint64_t clusters_drawn);

}  // namespace vgeo
