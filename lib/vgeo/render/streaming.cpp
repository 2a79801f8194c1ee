// Streaming in the renderer (streaming.h). Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021,
// §"Streaming requests" (the cull traversal requests what the cut wants) and §"Paging"
// (drawn clusters read from resident pages).
#include "vgeo/render/streaming.h"

#include <atomic>
#include <cassert>

#include "vgeo/core/error.h"
#include "vgeo/format/format.h"
#include "vgeo/render/frame.h"

namespace vgeo {

namespace {

// The metadata of a DAG (what the culling reads): everything but the vertex arrays.
ClusterDag metadata_copy(const ClusterDag& dag) {
  ClusterDag m;
  m.clusters = dag.clusters;
  m.groups = dag.groups;
  m.generated_clusters = dag.generated_clusters;
  m.bvh_nodes = dag.bvh_nodes;
  m.bounds = dag.bounds;
  m.level_count = dag.level_count;
  return m;
}

}  // namespace

void init_frame_streaming(RenderScene* scene, Streamer* streamer, const std::vector<uint32_t>& stream_mesh,
                          const std::vector<uint32_t>& material_offset, FrameStreaming* out) {
  const size_t n = scene->meshes.size();
  assert(stream_mesh.size() == n && material_offset.size() == n);
  out->streamer = streamer;
  out->stream_mesh = stream_mesh;
  out->material_offset = material_offset;
  out->geometry.assign(n, {});
  out->cluster_in_page.assign(n, {});
  out->bound_frame.assign(n, {});
  out->usable.assign(n, {});
  out->frame = 0;
  for (size_t m = 0; m < n; ++m) {
    if (stream_mesh[m] == kNone) {
      out->geometry[m] = std::move(scene->meshes[m]);
      scene->meshes[m] = metadata_copy(out->geometry[m]);
      continue;
    }
    const MeshMetadata& mm = streamer->container().meshes[stream_mesh[m]];
    ClusterDag& g = out->geometry[m];
    g.clusters = mm.dag.clusters;  // offsets rewritten per frame for the drawn clusters
    g.level_count = mm.dag.level_count;
    std::vector<uint32_t>& in_page = out->cluster_in_page[m];
    in_page.assign(mm.dag.clusters.size(), kNone);
    for (uint32_t slot = 0; slot < mm.page_clusters.size(); ++slot) {
      const uint32_t c = mm.page_clusters[slot];
      in_page[c] = slot - streamer->container().pages[mm.cluster_page[c]].first_cluster_slot;
    }
    out->bound_frame[m].assign(mm.dag.clusters.size(), 0);
  }
}

void refresh_usable_groups(const RenderScene& scene, FrameStreaming* s) {
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    if (s->stream_mesh[m] != kNone) s->usable[m] = s->streamer->usable(s->stream_mesh[m]);
}

void begin_streamed_frame(const RenderScene& scene, FrameStreaming* s) {
  ++s->frame;
  s->stats = s->streamer->begin_frame();
  refresh_usable_groups(scene, s);
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    ClusterDag& g = s->geometry[m];
    if (s->stream_mesh[m] == kNone) continue;
    g.positions.clear();
    g.normals.clear();
    g.indices.clear();
    g.triangle_materials.clear();
  }
}

void bind_streamed_geometry(FrameStreaming* s, const RenderScene& scene, const std::vector<VisibleCluster>& visible,
                            size_t first, ThreadPool& pool) {
  struct Job {
    uint32_t mesh, cluster;
  };
  std::vector<Job> jobs;
  for (size_t i = first; i < visible.size(); ++i) {
    const uint32_t m = scene.instances[visible[i].instance].mesh;
    if (s->stream_mesh[m] == kNone) continue;
    uint64_t& bound = s->bound_frame[m][visible[i].cluster];
    if (bound == s->frame) continue;
    bound = s->frame;
    ClusterDag& g = s->geometry[m];
    DagCluster& c = g.clusters[visible[i].cluster];
    // Sequential offsets into this frame's arrays (the vertex/triangle counts are metadata).
    c.vertex_offset = uint32_t(g.positions.size() / 3);
    c.triangle_offset = c.material_offset = uint32_t(g.indices.size() / 3);
    const bool normals = s->streamer->container().meshes[s->stream_mesh[m]].quantization.has_normals;
    g.positions.resize(g.positions.size() + 3 * size_t(c.vertex_count));
    if (normals) g.normals.resize(g.positions.size());
    g.indices.resize(g.indices.size() + 3 * size_t(c.triangle_count));
    g.triangle_materials.resize(g.indices.size() / 3);
    jobs.push_back({m, visible[i].cluster});
  }
  if (jobs.empty()) return;
  std::vector<DecodedCluster> scratch(pool.size());
  std::vector<uint8_t> mismatch(jobs.size(), 0);
  std::atomic<size_t> next{0};
  pool.run_on_all([&](unsigned worker) {
   DecodedCluster& dc = scratch[worker];
   for (;;) {
    const size_t j = next.fetch_add(1);
    if (j >= jobs.size()) return;
    const Job& job = jobs[j];
    const uint32_t sm = s->stream_mesh[job.mesh];
    const MeshMetadata& mm = s->streamer->container().meshes[sm];
    const uint32_t page = mm.cluster_page[job.cluster];
    assert(s->streamer->page_state(page) == PageState::kResident);
    ClusterDag& g = s->geometry[job.mesh];
    const DagCluster& c = g.clusters[job.cluster];
    decode_cluster(s->streamer->page_words(page).data(), s->cluster_in_page[job.mesh][job.cluster], mm.quantization, &dc);
    if (dc.vertex_count != c.vertex_count || dc.triangle_count != c.triangle_count) {
      mismatch[j] = 1;
      continue;
    }
    std::copy(dc.positions.begin(), dc.positions.end(), g.positions.begin() + 3 * size_t(c.vertex_offset));
    if (!g.normals.empty() && mm.quantization.has_normals)
      std::copy(dc.normals.begin(), dc.normals.end(), g.normals.begin() + 3 * size_t(c.vertex_offset));
    std::copy(dc.indices.begin(), dc.indices.end(), g.indices.begin() + 3 * size_t(c.triangle_offset));
    for (uint32_t t = 0; t < c.triangle_count; ++t)
      g.triangle_materials[c.triangle_offset + t] = dc.materials[t] + s->material_offset[job.mesh];
   }
  });
  for (size_t j = 0; j < jobs.size(); ++j)
    if (mismatch[j])
      fail(kErrInconsistent, "stream", "cluster " + std::to_string(jobs[j].cluster) +
                                           ": page geometry disagrees with the metadata's vertex/triangle counts");
}

void end_streamed_frame(FrameStreaming* s, const std::vector<GroupRequest>& requests, uint64_t clusters_coarser,
                        uint64_t clusters_drawn) {
  s->requests.clear();
  const std::vector<GroupRequest>* lists[2] = {&requests, &s->shadow_requests};
  for (const std::vector<GroupRequest>* list : lists)
    for (const GroupRequest& r : *list)
      if (s->stream_mesh[r.mesh] != kNone) s->requests.push_back({s->stream_mesh[r.mesh], r.group, r.priority});
  s->shadow_requests.clear();
  s->stats.clusters_drawn = uint32_t(clusters_drawn);
  s->stats.clusters_coarser = uint32_t(clusters_coarser);
  s->stats.cut_is_ideal = clusters_coarser == 0;
  s->streamer->end_frame(s->requests, &s->stats);
  s->streamer->count_frame_cut(s->stats.cut_is_ideal);
}

}  // namespace vgeo
