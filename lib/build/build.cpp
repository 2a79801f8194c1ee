// The DAG builder driver: cluster → (group → simplify → split) per level → BVH → layout.
// Normative description: spec/dag.md.
#include "vgeo/build/build.h"

#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstring>

#include "vgeo/build/build_internal.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"
#include "vgeo/core/thread_pool.h"

namespace vgeo {

using namespace build_detail;

namespace {

double now_seconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

struct WorkCluster {
  TriangleSet triangles;
  uint32_t level = 0;
  uint32_t group = kNone;             // work group index
  uint32_t generating_group = kNone;  // work group index
  Sphere bounds, lod_bounds;
  float lod_error = 0.0f;
};

struct WorkGroup {
  std::vector<uint32_t> members;    // work cluster indices
  std::vector<uint32_t> generated;  // work cluster indices
  uint32_t level = 0;
  bool terminal = false;
  Sphere bounds, parent_bounds;
  float parent_error = 0.0f;
};

void validate_mesh(const Mesh& mesh) {
  const std::string where = mesh.name.empty() ? "<mesh>" : mesh.name;
  if (mesh.positions.size() % 3 != 0 || mesh.indices.size() % 3 != 0)
    fail("BUILD_BAD_MESH", where, "position or index array length is not a multiple of 3");
  if (mesh.triangle_count() == 0) fail("BUILD_EMPTY_MESH", where, "the mesh has no triangles");
  // Offsets in the DAG are 32-bit and the DAG stores about twice the input.
  if (mesh.triangle_count() > (size_t(1) << 30) || mesh.vertex_count() >= kNone)
    fail("BUILD_MESH_TOO_LARGE", where, "more than 2^30 triangles or 2^32-1 vertices");
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
    fail("BUILD_BAD_MESH", where, "normals are not one per vertex");
  if (!mesh.uvs.empty() && mesh.uvs.size() != 2 * mesh.vertex_count())
    fail("BUILD_BAD_MESH", where, "uvs are not one per vertex");
  if (!mesh.materials.empty() && mesh.materials.size() != mesh.triangle_count())
    fail("BUILD_BAD_MESH", where, "materials are not one per triangle");
  for (float p : mesh.positions)
    if (!std::isfinite(p)) fail("BUILD_NONFINITE_POSITION", where, "a vertex position is NaN or infinite");
  size_t vcount = mesh.vertex_count();
  for (uint32_t i : mesh.indices)
    if (i >= vcount)
      fail("BUILD_INDEX_OUT_OF_RANGE", where,
           "index " + std::to_string(i) + " >= vertex count " + std::to_string(vcount));
}

Sphere cluster_sphere(const Mesh& mesh, const TriangleSet& t) {
  return sphere_of_points(mesh, t.corners.data(), t.corners.size());
}

// Leaf clustering input, cut into chunks of about kLeafChunkTriangles (see build_dag).
std::vector<TriangleSet> leaf_chunks(const Mesh& mesh) {
  size_t n = mesh.triangle_count();
  std::vector<TriangleSet> chunks;
  if (n <= kLeafChunkTriangles) {
    TriangleSet all;
    all.corners = mesh.indices;
    all.materials.resize(n);
    for (size_t t = 0; t < n; ++t) all.materials[t] = mesh.material(t);
    chunks.push_back(std::move(all));
    return chunks;
  }
  Aabb box;
  for (uint32_t i : mesh.indices) box.extend(mesh.position(i));
  constexpr uint32_t kCells = 16;  // per axis: 4096 cells, ≥ 2 chunks' worth each on 10M+
  auto cell_of = [&](size_t t) {
    uint32_t q[3];
    for (int k = 0; k < 3; ++k) {
      double c = (double(mesh.position(mesh.indices[3 * t])[k]) + mesh.position(mesh.indices[3 * t + 1])[k] +
                  mesh.position(mesh.indices[3 * t + 2])[k]) / 3.0;
      double extent = double(box.max[k]) - box.min[k];
      double f = extent > 0 ? (c - box.min[k]) / extent : 0.0;
      q[k] = uint32_t(std::clamp(f * kCells, 0.0, double(kCells - 1)));
    }
    uint32_t code = 0;
    for (int b = 3; b >= 0; --b)
      for (int k = 0; k < 3; ++k) code = (code << 1) | ((q[k] >> b) & 1);
    return code;
  };
  std::vector<uint16_t> cell(n);
  std::vector<size_t> count(kCells * kCells * kCells + 1, 0);
  for (size_t t = 0; t < n; ++t) {
    cell[t] = uint16_t(cell_of(t));
    ++count[cell[t] + 1];
  }
  for (size_t c = 0; c + 1 < count.size(); ++c) count[c + 1] += count[c];
  std::vector<uint32_t> order(n);
  {
    std::vector<size_t> fill(count.begin(), count.end() - 1);
    for (size_t t = 0; t < n; ++t) order[fill[cell[t]]++] = uint32_t(t);
  }
  TriangleSet current;
  auto flush = [&] {
    if (current.triangle_count()) chunks.push_back(std::move(current));
    current = TriangleSet();
  };
  for (size_t c = 0; c + 1 < count.size(); ++c) {
    for (size_t i = count[c]; i < count[c + 1]; ++i) {
      uint32_t t = order[i];
      current.corners.insert(current.corners.end(), &mesh.indices[3 * size_t(t)], &mesh.indices[3 * size_t(t)] + 3);
      current.materials.push_back(mesh.material(t));
    }
    if (current.triangle_count() >= kLeafChunkTriangles) flush();
  }
  flush();
  return chunks;
}

// ---- BVH8 over groups: top-down, split at the median of the largest centre extent ----
struct BvhBuilder {
  const std::vector<DagGroup>& groups;
  std::vector<BvhNode>& nodes;

  void split(std::vector<uint32_t>& items, size_t begin, size_t end, int depth,
             std::vector<std::pair<size_t, size_t>>& buckets) {
    if (depth == 0 || end - begin <= 1) {
      buckets.push_back({begin, end});
      return;
    }
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (size_t i = begin; i < end; ++i)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], double(groups[items[i]].bounds.center[k]));
        hi[k] = std::max(hi[k], double(groups[items[i]].bounds.center[k]));
      }
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (hi[k] - lo[k] > hi[axis] - lo[axis]) axis = k;
    std::sort(items.begin() + begin, items.begin() + end, [&](uint32_t a, uint32_t b) {
      float ca = groups[a].bounds.center[axis], cb = groups[b].bounds.center[axis];
      return ca != cb ? ca < cb : a < b;
    });
    size_t mid = begin + (end - begin) / 2;
    split(items, begin, mid, depth - 1, buckets);
    split(items, mid, end, depth - 1, buckets);
  }

  uint32_t build(std::vector<uint32_t>& items, size_t begin, size_t end) {
    uint32_t index = uint32_t(nodes.size());
    nodes.emplace_back();
    BvhNode node;
    std::vector<Sphere> bounds, lod_bounds;
    float max_error = 0.0f;
    auto add_group = [&](uint32_t g) {
      node.group_mask |= 1u << node.child_count;
      node.children[node.child_count++] = g;
      bounds.push_back(groups[g].bounds);
      lod_bounds.push_back(groups[g].parent_bounds);
      max_error = std::max(max_error, groups[g].parent_error);
    };
    if (end - begin <= kBvhMaxChildren) {
      for (size_t i = begin; i < end; ++i) add_group(items[i]);
    } else {
      std::vector<std::pair<size_t, size_t>> buckets;
      split(items, begin, end, 3, buckets);  // 2^3 = kBvhMaxChildren buckets
      for (auto [b, e] : buckets) {
        if (b == e) continue;
        if (e - b == 1) {
          add_group(items[b]);
          continue;
        }
        uint32_t child = build(items, b, e);
        node.children[node.child_count++] = child;
        bounds.push_back(nodes[child].bounds);
        lod_bounds.push_back(nodes[child].lod_bounds);
        max_error = std::max(max_error, nodes[child].max_parent_error);
      }
    }
    node.bounds = enclose_spheres(bounds.data(), bounds.size());
    node.lod_bounds = enclose_spheres(lod_bounds.data(), lod_bounds.size());
    node.max_parent_error = max_error;
    nodes[index] = node;
    return index;
  }
};

}  // namespace

ClusterDag build_dag(const Mesh& mesh, const BuildOptions& options, BuildReport* report) {
  return build_dag_internal(mesh, options, InternalBuildOptions{}, report);
}

ClusterDag build_detail::build_dag_internal(const Mesh& mesh, const BuildOptions& options,
                                            const InternalBuildOptions& internal, BuildReport* report) {
  double t_start = now_seconds();
  validate_mesh(mesh);
  BuildReport rep;
  rep.input_triangles = mesh.triangle_count();
  ThreadPool pool(options.threads);
  WeldedMesh welded = weld_positions(mesh);
  const size_t vertex_count = mesh.vertex_count();
  // Per-task scratch arrays (vertex_count entries, kept all-kNone between uses) come from
  // a small locked free list: parallel_for does not tell a task which worker runs it.
  std::mutex scratch_mutex;
  std::vector<std::vector<uint32_t>> scratch_pool;
  auto take_scratch = [&]() {
    std::lock_guard<std::mutex> lock(scratch_mutex);
    if (scratch_pool.empty()) return std::vector<uint32_t>(vertex_count, kNone);
    std::vector<uint32_t> s = std::move(scratch_pool.back());
    scratch_pool.pop_back();
    return s;
  };
  auto give_scratch = [&](std::vector<uint32_t>&& s) {
    std::lock_guard<std::mutex> lock(scratch_mutex);
    scratch_pool.push_back(std::move(s));
  };
  Progress progress("build", mesh.triangle_count(), options.progress);

  // ---- leaves ----
  std::vector<WorkCluster> clusters;
  std::vector<WorkGroup> groups;
  {
    double t0 = now_seconds();
    // Large meshes are cut into spatially coherent chunks (cells of a 16^3 grid in Morton
    // order, consecutive cells merged up to kLeafChunkTriangles) clustered in parallel.
    // The chunking depends only on the mesh, so the output does not depend on threads.
    std::vector<TriangleSet> chunks = leaf_chunks(mesh);
    std::vector<std::vector<TriangleSet>> chunk_leaves(chunks.size());
    pool.parallel_for(chunks.size(), [&](size_t i) {
      std::vector<uint32_t> s = take_scratch();
      chunk_leaves[i] = split_into_clusters(welded, chunks[i], s, internal.leaf_split);
      give_scratch(std::move(s));
      chunks[i] = TriangleSet();
    });
    std::vector<TriangleSet> leaves;
    for (auto& cl : chunk_leaves)
      for (TriangleSet& t : cl) leaves.push_back(std::move(t));
    chunk_leaves.clear();
    clusters.resize(leaves.size());
    pool.parallel_for(leaves.size(), [&](size_t i) {
      WorkCluster& c = clusters[i];
      c.triangles = std::move(leaves[i]);
      c.bounds = cluster_sphere(mesh, c.triangles);
      c.lod_bounds = c.bounds;
    });
    rep.seconds_cluster = now_seconds() - t0;
  }

  // Welded vertices of retired (terminal) clusters: locked for every later level, since
  // those clusters stay drawable next to anything coarser (spec/dag.md §Locks).
  std::vector<uint8_t> retired(vertex_count, 0);
  std::vector<uint64_t> retired_edges;  // sorted welded edge keys of retired clusters
  std::vector<uint32_t> owner(vertex_count, kNone);
  std::vector<uint8_t> locked(vertex_count, 0);

  std::vector<uint32_t> active(clusters.size());
  for (size_t i = 0; i < active.size(); ++i) active[i] = uint32_t(i);
  size_t processed = 0;
  for (uint32_t level = 0; !active.empty(); ++level) {
    BuildLevelReport lr;
    lr.level = level;
    std::vector<std::vector<uint64_t>> open_keys;  // per active cluster, for grouping
    lr.clusters = active.size();
    {
      std::vector<uint64_t> open(active.size()), all(active.size());
      open_keys.assign(active.size(), {});
      pool.parallel_for(active.size(), [&](size_t i) {
        count_cluster_edges(welded, clusters[active[i]].triangles, &open[i], &all[i], &open_keys[i]);
      });
      uint64_t so = 0, sa = 0;
      for (size_t i = 0; i < active.size(); ++i) {
        so += open[i];
        sa += all[i];
        lr.triangles += clusters[active[i]].triangles.triangle_count();
      }
      lr.boundary_edge_fraction = sa ? double(so) / double(sa) : 0.0;
      lr.average_fill = double(lr.triangles) / double(active.size()) / kMaxClusterTriangles;
    }

    // ---- group ----
    double t0 = now_seconds();
    std::vector<std::vector<uint32_t>> level_groups;
    bool last_level = level + 1 >= kMaxLevels;
    if (active.size() == 1 || last_level) {
      for (uint32_t c : active) level_groups.push_back({c});
      if (active.size() > 1) level_groups = {active};
    } else {
      std::vector<const TriangleSet*> sets(active.size());
      std::vector<Sphere> bounds(active.size());
      for (size_t i = 0; i < active.size(); ++i) {
        sets[i] = &clusters[active[i]].triangles;
        bounds[i] = clusters[active[i]].bounds;
      }
      level_groups = group_clusters(sets, open_keys, bounds, internal.group_target_clusters);
      for (auto& g : level_groups)
        for (uint32_t& m : g) m = active[m];
    }
    uint32_t first_group = uint32_t(groups.size());
    for (auto& members : level_groups) {
      WorkGroup g;
      g.members = std::move(members);
      g.level = level;
      uint32_t gi = uint32_t(groups.size());
      std::vector<Sphere> b, lb;
      float max_child = 0.0f;
      for (uint32_t m : g.members) {
        clusters[m].group = gi;
        b.push_back(clusters[m].bounds);
        lb.push_back(clusters[m].lod_bounds);
        max_child = std::max(max_child, clusters[m].lod_error);
      }
      g.bounds = enclose_spheres(b.data(), b.size());
      g.parent_bounds = enclose_spheres(lb.data(), lb.size());
      g.parent_error = max_child;
      groups.push_back(std::move(g));
    }
    uint32_t group_count = uint32_t(groups.size()) - first_group;
    lr.groups = group_count;

    // Locks: welded vertices used by two groups of this level, or by a retired cluster.
    // Parallel over clusters: the first group to claim a vertex owns it, any other group
    // locks it, so `locked` does not depend on the order (only `owner` does, and it is
    // only reset below). Locks only ever go 0 → 1 within a level.
    pool.parallel_for(active.size(), [&](size_t i) {
      const WorkCluster& cl = clusters[active[i]];
      const uint32_t g = cl.group;
      for (uint32_t v : cl.triangles.corners) {
        uint32_t w = welded.weld[v];
        uint32_t expected = kNone;
        if ((!std::atomic_ref<uint32_t>(owner[w]).compare_exchange_strong(expected, g, std::memory_order_relaxed) &&
             expected != g) ||
            retired[w])
          std::atomic_ref<uint8_t>(locked[w]).store(1, std::memory_order_relaxed);
      }
    });
    // Shared edges: welded edges with both ends locked used by two groups of this level or
    // by a retired cluster (only those must survive; few: they lie on group borders).
    std::vector<uint64_t> shared_edges;
    {
      std::vector<std::vector<std::pair<uint64_t, uint32_t>>> per_cluster(active.size());
      pool.parallel_for(active.size(), [&](size_t ci) {
        const TriangleSet& t = clusters[active[ci]].triangles;
        const uint32_t g = clusters[active[ci]].group;
        for (size_t i = 0; i < t.triangle_count(); ++i)
          for (int k = 0; k < 3; ++k) {
            uint32_t a = welded.weld[t.corners[3 * i + k]], b = welded.weld[t.corners[3 * i + (k + 1) % 3]];
            if (a != b && locked[a] && locked[b]) per_cluster[ci].push_back({edge_key(a, b), g});
          }
      });
      std::vector<std::pair<uint64_t, uint32_t>> candidates;
      {
        size_t total = 0;
        for (const auto& v : per_cluster) total += v.size();
        candidates.reserve(total);
        for (const auto& v : per_cluster) candidates.insert(candidates.end(), v.begin(), v.end());
      }
      std::sort(candidates.begin(), candidates.end());
      for (size_t i = 0; i < candidates.size();) {
        size_t j = i;
        bool shared = false;
        while (j < candidates.size() && candidates[j].first == candidates[i].first) {
          shared |= candidates[j].second != candidates[i].second;
          ++j;
        }
        if (shared || std::binary_search(retired_edges.begin(), retired_edges.end(), candidates[i].first))
          shared_edges.push_back(candidates[i].first);
        i = j;
      }
    }
    rep.seconds_group += now_seconds() - t0;

    // ---- simplify + split, per group in parallel, results in per-group slots ----
    struct GroupResult {
      bool terminal = true;
      float error = 0.0f;
      std::vector<TriangleSet> clusters;
      double seconds_simplify = 0, seconds_split = 0;
    };
    std::vector<GroupResult> results(group_count);
    bool simplify_allowed = !(active.size() == 1 || last_level);
    pool.parallel_for(group_count, [&](size_t i) {
      if (!simplify_allowed) return;
      const WorkGroup& g = groups[first_group + i];
      GroupResult& r = results[i];
      double ts = now_seconds();
      TriangleSet merged;
      for (uint32_t m : g.members) {
        const TriangleSet& t = clusters[m].triangles;
        merged.corners.insert(merged.corners.end(), t.corners.begin(), t.corners.end());
        merged.materials.insert(merged.materials.end(), t.materials.begin(), t.materials.end());
      }
      SimplifyResult s = simplify_group(welded, merged, locked, options.simplifier);
      size_t before = merged.triangle_count(), after = s.triangles.triangle_count();
      bool enough = after > 0 && double(after) <= double(before) * (1.0 - kMinReduction);
      bool sealed = enough && locked_border_preserved(welded, merged, s.triangles, locked, shared_edges);
      double tm = now_seconds();
      r.seconds_simplify = tm - ts;
      if (!sealed) return;
      std::vector<uint32_t> sc = take_scratch();
      r.clusters = split_into_clusters(welded, s.triangles, sc, internal.group_split);
      give_scratch(std::move(sc));
      r.seconds_split = now_seconds() - tm;
      r.terminal = false;
      // The stored error is a promise lib/verify checks (ERROR_BOUND): the backends'
      // estimates (meshopt's quadric, OpenMesh's removed-vertex distance) can be below the
      // distance from the simplified surface back to its input, so measure that too.
      r.error = simplification_error(*welded.mesh, merged, s.triangles, s.error);
    });

    // ---- combine in group order ----
    std::vector<uint32_t> next;
    std::vector<uint64_t> new_retired_edges;
    for (uint32_t i = 0; i < group_count; ++i) {
      GroupResult& r = results[i];
      uint32_t gi = first_group + i;
      rep.seconds_simplify += r.seconds_simplify / pool.size();
      rep.seconds_split += r.seconds_split / pool.size();
      if (r.terminal) {
        groups[gi].terminal = true;
        groups[gi].parent_error = kTerminalError;
        ++lr.stuck_groups;
        for (uint32_t m : groups[gi].members) {
          const TriangleSet& t = clusters[m].triangles;
          for (uint32_t v : t.corners) retired[welded.weld[v]] = 1;
          for (size_t k = 0; k < t.corners.size(); ++k) {
            uint32_t a = welded.weld[t.corners[k]], b = welded.weld[t.corners[k - k % 3 + (k + 1) % 3]];
            if (a != b) new_retired_edges.push_back(edge_key(a, b));
          }
        }
        continue;
      }
      // parent_error = max(member lod_error) + own error; float addition of a
      // non-negative term never goes below the max, so monotonicity holds exactly.
      float own = std::isfinite(r.error) && r.error > 0 ? r.error : 0.0f;
      groups[gi].parent_error = groups[gi].parent_error + own;
      for (TriangleSet& t : r.clusters) {
        WorkCluster c;
        c.triangles = std::move(t);
        c.level = level + 1;
        c.generating_group = gi;
        c.lod_bounds = groups[gi].parent_bounds;
        c.lod_error = groups[gi].parent_error;
        groups[gi].generated.push_back(uint32_t(clusters.size()));
        next.push_back(uint32_t(clusters.size()));
        clusters.push_back(std::move(c));
      }
    }
    if (active.size() == 1 || last_level) lr.stuck_groups = 0;  // roots by construction, not stuck
    pool.parallel_for(next.size(), [&](size_t i) {
      WorkCluster& c = clusters[next[i]];
      c.bounds = cluster_sphere(mesh, c.triangles);
    });
    // Reset per-level lock state (only the touched entries; the same values from any task).
    pool.parallel_for(active.size(), [&](size_t i) {
      for (uint32_t v : clusters[active[i]].triangles.corners) {
        uint32_t w = welded.weld[v];
        std::atomic_ref<uint32_t>(owner[w]).store(kNone, std::memory_order_relaxed);
        std::atomic_ref<uint8_t>(locked[w]).store(0, std::memory_order_relaxed);
      }
    });
    if (!new_retired_edges.empty()) {
      retired_edges.insert(retired_edges.end(), new_retired_edges.begin(), new_retired_edges.end());
      std::sort(retired_edges.begin(), retired_edges.end());
      retired_edges.erase(std::unique(retired_edges.begin(), retired_edges.end()), retired_edges.end());
    }
    processed += lr.triangles;
    progress.set(std::min<size_t>(processed, mesh.triangle_count()));
    rep.levels.push_back(lr);
    active = std::move(next);
  }

  // ---- layout: groups in creation order (sorted by level), clusters sorted by group ----
  double th = now_seconds();
  ClusterDag dag;
  std::vector<uint32_t> new_index(clusters.size(), kNone);
  {
    uint32_t next = 0;
    for (const WorkGroup& g : groups)
      for (uint32_t m : g.members) new_index[m] = next++;
    assert(next == clusters.size());
  }
  dag.groups.resize(groups.size());
  dag.clusters.resize(clusters.size());
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const WorkGroup& w = groups[gi];
    DagGroup& g = dag.groups[gi];
    g.first_cluster = new_index[w.members.front()];
    g.cluster_count = uint32_t(w.members.size());
    g.first_generated = uint32_t(dag.generated_clusters.size());
    g.generated_count = uint32_t(w.generated.size());
    for (uint32_t c : w.generated) dag.generated_clusters.push_back(new_index[c]);
    g.level = w.level;
    g.flags = w.terminal ? kGroupTerminal : 0u;
    g.bounds = w.bounds;
    g.parent_bounds = w.parent_bounds;
    g.parent_error = w.parent_error;
    dag.level_count = std::max(dag.level_count, w.level + 1);
  }
  // Vertex/triangle offsets need a prefix sum over the final order.
  std::vector<uint32_t> order(clusters.size());
  for (size_t i = 0; i < clusters.size(); ++i) order[new_index[i]] = uint32_t(i);
  std::vector<std::vector<uint32_t>> cluster_vertices(clusters.size());
  // Per cluster: distinct original vertices in order of first use, and local corners.
  std::vector<std::vector<uint8_t>> cluster_local(clusters.size());
  pool.parallel_for(clusters.size(), [&](size_t i) {
    const TriangleSet& t = clusters[order[i]].triangles;
    std::vector<uint32_t>& verts = cluster_vertices[i];
    std::vector<uint8_t>& local = cluster_local[i];
    local.resize(t.corners.size());
    // Open addressing over ≤ 384 corners: 1024 slots keep probes short.
    constexpr size_t kSlots = 1024;
    uint32_t key[kSlots], val[kSlots];
    std::fill(key, key + kSlots, kNone);
    for (size_t k = 0; k < t.corners.size(); ++k) {
      uint32_t v = t.corners[k];
      size_t h = (v * 0x9E3779B1u) >> 22;
      while (key[h] != kNone && key[h] != v) h = (h + 1) & (kSlots - 1);
      if (key[h] == kNone) {
        key[h] = v;
        val[h] = uint32_t(verts.size());
        verts.push_back(v);
      }
      local[k] = uint8_t(val[h]);
    }
  });
  size_t total_vertices = 0, total_triangles = 0;
  for (size_t i = 0; i < clusters.size(); ++i) {
    total_vertices += cluster_vertices[i].size();
    total_triangles += clusters[order[i]].triangles.triangle_count();
  }
  if (total_vertices >= kNone || total_triangles >= kNone)
    fail("BUILD_MESH_TOO_LARGE", mesh.name, "the DAG would exceed 2^32 vertices or triangles");
  dag.positions.resize(3 * total_vertices);
  if (!mesh.normals.empty()) dag.normals.resize(3 * total_vertices);
  if (!mesh.uvs.empty()) dag.uvs.resize(2 * total_vertices);
  dag.indices.resize(3 * total_triangles);
  dag.triangle_materials.resize(total_triangles);
  {
    uint32_t vo = 0, to = 0;
    for (size_t i = 0; i < clusters.size(); ++i) {
      const WorkCluster& w = clusters[order[i]];
      DagCluster& c = dag.clusters[i];
      c.vertex_offset = vo;
      c.vertex_count = uint32_t(cluster_vertices[i].size());
      c.triangle_offset = to;
      c.triangle_count = uint32_t(w.triangles.triangle_count());
      c.material_offset = to;
      c.group = w.group;
      c.generating_group = w.generating_group;
      c.level = w.level;
      c.bounds = w.bounds;
      c.lod_bounds = w.lod_bounds;
      c.lod_error = w.lod_error;
      c.parent_bounds = groups[w.group].parent_bounds;
      c.parent_error = groups[w.group].parent_error;
      assert(c.triangle_count >= 1 && c.triangle_count <= kMaxClusterTriangles);
      assert(c.vertex_count <= kMaxClusterVertices);
      vo += c.vertex_count;
      to += c.triangle_count;
    }
  }
  pool.parallel_for(clusters.size(), [&](size_t i) {
    const WorkCluster& w = clusters[order[i]];
    const DagCluster& c = dag.clusters[i];
    const std::vector<uint32_t>& verts = cluster_vertices[i];
    for (size_t k = 0; k < verts.size(); ++k) {
      size_t dst = c.vertex_offset + k, src = verts[k];
      std::memcpy(&dag.positions[3 * dst], &mesh.positions[3 * src], 12);
      if (!dag.normals.empty()) std::memcpy(&dag.normals[3 * dst], &mesh.normals[3 * src], 12);
      if (!dag.uvs.empty()) std::memcpy(&dag.uvs[2 * dst], &mesh.uvs[2 * src], 8);
    }
    std::memcpy(&dag.indices[3 * size_t(c.triangle_offset)], cluster_local[i].data(), 3 * size_t(c.triangle_count));
    for (size_t t = 0; t < c.triangle_count; ++t) dag.triangle_materials[c.triangle_offset + t] = w.triangles.materials[t];
  });
  {
    // Only vertices referenced by triangles count as leaf positions.
    Aabb b;
    for (uint32_t i : mesh.indices) b.extend(mesh.position(i));
    dag.bounds = b;
  }

  // ---- culling hierarchy ----
  if (!dag.groups.empty()) {
    std::vector<uint32_t> items(dag.groups.size());
    for (size_t i = 0; i < items.size(); ++i) items[i] = uint32_t(i);
    BvhBuilder bvh{dag.groups, dag.bvh_nodes};
    bvh.build(items, 0, items.size());
  }
  rep.seconds_hierarchy = now_seconds() - th;

  rep.stored_triangles = dag.triangle_count();
  for (const DagGroup& g : dag.groups)
    if (g.flags & kGroupTerminal) {
      rep.root_clusters += g.cluster_count;
      for (uint32_t c = g.first_cluster; c < g.first_cluster + g.cluster_count; ++c)
        rep.root_triangles += dag.clusters[c].triangle_count;
    }
  rep.seconds_total = now_seconds() - t_start;
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) == 0) rep.peak_memory_bytes = uint64_t(usage.ru_maxrss) * 1024;
  if (report) *report = std::move(rep);
  return dag;
}

BuiltScene build_scene(const Scene& scene, const BuildOptions& options, std::vector<BuildReport>* reports) {
  BuiltScene out;
  out.materials = scene.materials;
  out.instances = scene.instances;
  if (reports) reports->clear();
  for (const Mesh& m : scene.meshes) {
    BuildReport r;
    out.meshes.push_back(build_dag(m, options, &r));
    if (reports) reports->push_back(std::move(r));
  }
  return out;
}

}  // namespace vgeo
