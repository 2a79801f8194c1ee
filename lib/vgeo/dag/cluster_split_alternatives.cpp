// The splitters kept for measurement (SplitMethod::kMeshopt, SplitMethod::kMetis): used by
// tests, `vgeo bench dagquality` and the cluster split benchmark, never by a default build
// (spec/dag.md §2.2, measured in §5).
// Based on: Kapoulkine, meshoptimizer 0.18, meshopt_buildMeshlets (called, not reimplemented;
// the previous default, the reference the grower reproduces); Karypis, Kumar, "A Fast and High
// Quality Multilevel Scheme for Partitioning Irregular Graphs", SIAM J. Sci. Comput. 20(1), 1998
// (METIS, the recursive bisection).
#include <meshoptimizer.h>
#include <metis.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

// ---- meshopt_buildMeshlets (SplitMethod::kMeshopt) ----
std::vector<TriangleSet> meshopt_clusters(const WeldedMesh& welded, const TriangleSet& tris,
                                          std::vector<uint32_t>& scratch) {
  const Mesh& mesh = *welded.mesh;
  size_t tri_count = tris.triangle_count();
  std::vector<uint32_t> local;
  std::vector<uint32_t> welded_of_local = compact_welded(welded, tris, scratch, local);
  size_t vcount = welded_of_local.size();
  std::vector<float> positions(3 * vcount);
  for (size_t i = 0; i < vcount; ++i)
    std::memcpy(&positions[3 * i], &mesh.positions[3 * size_t(welded_of_local[i])], 12);

  size_t max_meshlets = meshopt_buildMeshletsBound(local.size(), kMaxClusterVertices, kMaxClusterTriangles);
  std::vector<meshopt_Meshlet> meshlets(max_meshlets);
  // Worst-case sized output arrays that meshopt fills only in part (a cluster rarely reaches
  // both limits): left uninitialised, so only the pages it writes are touched (a zero fill
  // cost 1-3% of a build's CPU and its whole size in resident memory).
  std::unique_ptr<unsigned int[]> meshlet_vertices(new unsigned int[max_meshlets * kMaxClusterVertices]);
  std::unique_ptr<unsigned char[]> meshlet_triangles(new unsigned char[max_meshlets * kMaxClusterTriangles * 3]);
  size_t meshlet_count = meshopt_buildMeshlets(meshlets.data(), meshlet_vertices.get(), meshlet_triangles.get(),
                                               local.data(), local.size(), positions.data(), vcount,
                                               sizeof(float) * 3, kMaxClusterVertices, kMaxClusterTriangles, 0.0f);

  // Map meshlet triangles back to input triangles: meshopt keeps each triangle's corner
  // order, so find an unused input triangle with the same local corners via the first
  // corner's triangle list.
  std::vector<uint32_t> first(vcount + 1, 0), list(3 * tri_count);
  for (size_t i = 0; i < local.size(); ++i) ++first[local[i] + 1];
  for (size_t v = 0; v < vcount; ++v) first[v + 1] += first[v];
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (size_t i = 0; i < local.size(); ++i) list[fill[local[i]]++] = uint32_t(i / 3);
  }
  std::vector<uint8_t> used(tri_count, 0);
  std::vector<TriangleSet> out;
  std::vector<uint32_t> ids;
  size_t assigned = 0;
  for (size_t m = 0; m < meshlet_count; ++m) {
    const meshopt_Meshlet& ml = meshlets[m];
    ids.clear();
    for (size_t t = 0; t < ml.triangle_count; ++t) {
      const unsigned char* lt = &meshlet_triangles[ml.triangle_offset + 3 * t];
      uint32_t a = meshlet_vertices[ml.vertex_offset + lt[0]];
      uint32_t b = meshlet_vertices[ml.vertex_offset + lt[1]];
      uint32_t c = meshlet_vertices[ml.vertex_offset + lt[2]];
      uint32_t found = kNone;
      for (uint32_t j = first[a]; j < first[a + 1]; ++j) {
        uint32_t tri = list[j];
        if (used[tri]) continue;
        const uint32_t* lc = &local[3 * size_t(tri)];
        if (lc[0] == a && lc[1] == b && lc[2] == c) {
          found = tri;
          break;
        }
      }
      if (found == kNone) continue;  // cannot happen; the sweep below keeps every triangle
      used[found] = 1;
      ids.push_back(found);
    }
    assigned += ids.size();
    if (!ids.empty()) emit_cluster(tris, ids.data(), ids.size(), scratch, out);
  }
  if (assigned != tri_count) {
    // Defensive: any triangle meshopt did not report (it reports all) still gets a cluster.
    ids.clear();
    for (size_t t = 0; t < tri_count; ++t)
      if (!used[t]) ids.push_back(uint32_t(t));
    for (size_t i = 0; i < ids.size(); i += kMaxClusterTriangles)
      emit_cluster(tris, ids.data() + i, std::min<size_t>(kMaxClusterTriangles, ids.size() - i), scratch, out);
  }
  return out;
}

// ---- METIS recursive bisection (SplitMethod::kMetis) ----
// Largest non-manifold fan linked as a clique in the dual graph (4 triangles = 6 links).
constexpr size_t kMaxFanClique = 4;

// Recursive bisection of the triangle dual graph (edges = shared welded edges) with METIS,
// weights proportional to the cluster counts on each side, so partitions come out close
// to full (Nanite: "graph partitioning with a strict upper bound, small slack").
void bisect_metis(const TriangleSet& tris, const std::vector<uint32_t>& local, std::vector<uint32_t>& ids,
                  std::vector<uint32_t>& scratch, std::vector<TriangleSet>& out) {
  size_t n = ids.size();
  if (n <= kMaxClusterTriangles) {
    emit_cluster(tris, ids.data(), n, scratch, out);
    return;
  }
  // Dual graph of this subset.
  std::vector<std::pair<uint64_t, uint32_t>> edges;
  edges.reserve(3 * n);
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = local[3 * size_t(ids[i]) + k], b = local[3 * size_t(ids[i]) + (k + 1) % 3];
      if (a != b) edges.push_back({edge_key(a, b), uint32_t(i)});
    }
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    // Non-manifold fans: link consecutive triangles only, so a fan of k triangles costs
    // O(k) graph edges, not O(k^2).
    bool fan = j - i > kMaxFanClique;
    for (size_t x = i; x < j; ++x)
      for (size_t y = x + 1; y < (fan ? std::min(j, x + 2) : j); ++y)
        if (edges[x].second != edges[y].second) {
          pairs.push_back({edges[x].second, edges[y].second});
          pairs.push_back({edges[y].second, edges[x].second});
        }
    i = j;
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::vector<idx_t> xadj(n + 1, 0), adjncy;
  adjncy.reserve(pairs.size());
  for (auto& p : pairs) {
    ++xadj[p.first + 1];
    adjncy.push_back(idx_t(p.second));
  }
  for (size_t i = 0; i < n; ++i) xadj[i + 1] += xadj[i];
  size_t clusters = (n + kMaxClusterTriangles - 1) / kMaxClusterTriangles;
  size_t left_clusters = clusters / 2;
  real_t tpwgts[2] = {real_t(double(left_clusters) / clusters), real_t(double(clusters - left_clusters) / clusters)};
  std::vector<idx_t> part(n, 0);
  idx_t nvtxs = idx_t(n), ncon = 1, nparts = 2, objval = 0;
  idx_t options[METIS_NOPTIONS];
  set_metis_options(options);
  int rc;
  {
    std::lock_guard<std::mutex> lock(metis_mutex());
    rc = metis_functions().part_graph_recursive(&nvtxs, &ncon, xadj.data(), adjncy.data(), nullptr, nullptr, nullptr,
                                                &nparts, tpwgts, nullptr, options, &objval, part.data());
  }
  std::vector<uint32_t> left, right;
  if (rc == METIS_OK) {
    for (size_t i = 0; i < n; ++i) (part[i] == 0 ? left : right).push_back(ids[i]);
  }
  // Slack: METIS may overshoot the target; cap the left side at its cluster budget and
  // fall back to an order split if it produced an empty side.
  size_t left_cap = left_clusters * kMaxClusterTriangles;
  if (left.empty() || right.empty()) {
    left.assign(ids.begin(), ids.begin() + std::min(n / 2, left_cap));
    right.assign(ids.begin() + left.size(), ids.end());
  } else if (left.size() > left_cap) {
    right.insert(right.end(), left.begin() + left_cap, left.end());
    left.resize(left_cap);
  }
  ids.clear();
  ids.shrink_to_fit();
  bisect_metis(tris, local, left, scratch, out);
  bisect_metis(tris, local, right, scratch, out);
}

}  // namespace

std::vector<TriangleSet> split_metis(const WeldedMesh& welded, const TriangleSet& tris,
                                     std::vector<uint32_t>& scratch) {
  std::vector<uint32_t> local;
  compact_welded(welded, tris, scratch, local);
  std::vector<uint32_t> ids(tris.triangle_count());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = uint32_t(i);
  std::vector<TriangleSet> out;
  bisect_metis(tris, local, ids, scratch, out);
  return out;
}

std::vector<TriangleSet> split_meshopt(const WeldedMesh& welded, const TriangleSet& tris,
                                       std::vector<uint32_t>& scratch) {
  return meshopt_clusters(welded, tris, scratch);
}

}  // namespace vgeo::build_detail
