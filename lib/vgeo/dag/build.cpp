// The DAG builder driver: cluster → (group → simplify → split) per level → BVH → layout.
// Normative description: spec/dag.md.
// Based on: Karis, Stubbe, Wihlidal, "Nanite: A Deep Dive", SIGGRAPH 2021 Advances in Real-Time
// Rendering, §"Build operations" (cluster; per level group, merge, simplify to half, split),
// §"LOD cracks solution" (group borders locked, so every cut is crack-free) and §"DAG".
#include "vgeo/dag/build.h"
#include "vgeo/core/process_memory.h"


#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <cmath>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>

#include "vgeo/dag/build_internal.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/mesh/validate.h"

namespace vgeo {

using namespace build_detail;

namespace {

// What the next level needs of a new cluster, computed by the task that made it, right after
// the split, while its corners, welded ids and positions are still in cache (a later pass
// over all clusters missed the cache on each: count_cluster_edges and the spheres were 5% of a
// 1M-triangle build). Not with vertex placement: there a group's clusters are renamed in
// combine_level (moved vertices get their ids there), so their edges and spheres come after.
struct ClusterFacts {
  bool counted = false;
  uint64_t open = 0, all = 0;       // count_cluster_edges
  std::vector<uint64_t> open_keys;  // open welded edges (grouping; moved out by count_level_edges)
  // Distinct welded ids of its corners in order of first use (empty: not listed). The lock
  // passes decide per vertex, and a vertex's later corners in one cluster change nothing (the
  // first one locked or claimed it for the same group), so they walk this list, a third of the
  // corners, without the weld lookups.
  std::vector<uint32_t> welded;
};
// (Kept per level, LevelState::facts, not in WorkCluster: every cluster's record lives until
// the layout, whose arrays are the build's peak memory.)

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

// spec/dag.md §6, with lib/vgeo/mesh's checks (the importers raise their own codes for them).
// The array sizes (checked before anything reads the arrays), then the values (a scan of
// every position and index).
void validate_mesh_sizes(const Mesh& mesh) {
  const std::string where = mesh.name.empty() ? "<mesh>" : mesh.name;
  if (mesh.positions.size() % 3 != 0 || mesh.indices.size() % 3 != 0)
    fail("BUILD_BAD_MESH", where, mesh_array_size_defect(mesh));
  if (mesh.triangle_count() == 0) fail("BUILD_EMPTY_MESH", where, "the mesh has no triangles");
  // Offsets in the DAG are 32-bit and the DAG stores about twice the input.
  if (mesh.triangle_count() > (size_t(1) << 30) || mesh.vertex_count() >= kNone)
    fail("BUILD_MESH_TOO_LARGE", where, "more than 2^30 triangles or 2^32-1 vertices");
  if (std::string defect = mesh_array_size_defect(mesh); !defect.empty()) fail("BUILD_BAD_MESH", where, defect);
}
void validate_mesh_values(const Mesh& mesh) {
  const std::string where = mesh.name.empty() ? "<mesh>" : mesh.name;
  if (first_non_finite(mesh.positions) < mesh.positions.size())
    fail("BUILD_NONFINITE_POSITION", where, "a vertex position is NaN or infinite");
  if (size_t i = first_index_out_of_range(mesh); i < mesh.indices.size())
    fail("BUILD_INDEX_OUT_OF_RANGE", where,
         "index " + std::to_string(mesh.indices[i]) + " >= vertex count " + std::to_string(mesh.vertex_count()));
}

Sphere cluster_sphere(const Mesh& mesh, const TriangleSet& t) {
  return sphere_of_points(mesh, t.corners.data(), t.corners.size());
}

// A new cluster's facts (ClusterFacts) and sphere, from one pass that lists its distinct
// welded ids in order of first use (marked in the task's scratch array, all kNone, returned
// so) and gives each corner its local id:
// - the sphere from those points: a copy sits exactly at its representative's position, and
//   sphere_of_points' box and farthest point are the same when later repeats of a point are
//   left out (a tie keeps the first), so this is cluster_sphere's value bit for bit from about
//   a third of the points;
// - the edges in local ids (count_local_edges: count_cluster_edges' counts and keys).
ClusterFacts cluster_facts(const Mesh& mesh, const WeldedMesh& welded, const TriangleSet& t,
                           std::vector<uint32_t>& scratch, Sphere& bounds) {
  ClusterFacts f;
  f.counted = true;
  constexpr size_t kMaxCorners = 3 * size_t(kMaxClusterTriangles);
  if (t.corners.size() > kMaxCorners) {  // not a cluster of the build (kept for safety)
    count_cluster_edges(welded, t, &f.open, &f.all, &f.open_keys);
    bounds = cluster_sphere(mesh, t);
    return f;
  }
  uint16_t local[kMaxCorners];
  uint32_t points[kMaxCorners];
  size_t count = 0;
  for (size_t i = 0; i < t.corners.size(); ++i) {
    const uint32_t w = welded.weld[t.corners[i]];
    if (scratch[w] == kNone) scratch[w] = uint32_t(count), points[count++] = w;
    local[i] = uint16_t(scratch[w]);
  }
  for (size_t i = 0; i < count; ++i) scratch[points[i]] = kNone;
  f.welded.assign(points, points + count);  // one allocation of the exact size
  bounds = sphere_of_points(mesh, points, count);
  count_local_edges(points, count, local, t.triangle_count(), &f.open, &f.all, &f.open_keys);
  return f;
}

// Calls fn(w) for each distinct welded id of cluster c's corners (`facts`, when it lists
// them), or for each corner's welded id.
template <class Fn>
void for_each_cluster_vertex(const WeldedMesh& welded, const WorkCluster& c, const ClusterFacts* facts, Fn&& fn) {
  if (facts && !facts->welded.empty()) {
    for (uint32_t w : facts->welded) fn(w);
  } else {
    for (uint32_t v : c.triangles.corners) fn(welded.weld[v]);
  }
}

// Leaf clustering input, cut into chunks of about kLeafChunkTriangles (see build_dag).
// Triangles per parallel_for task in the per-triangle passes (fixed, so results combined
// in task order do not depend on the thread count).
constexpr size_t kTrianglesPerTask = size_t(1) << 16;

// Groups per task of a lone block's lock and shared-edge passes (group_and_lock_block): a
// group is ~16 clusters, ~2,000 triangles, so 8 are ~50 µs of work per task against ~1 µs of
// hand-out, and a 4,096-cluster block still gives ~30 tasks to balance.
constexpr size_t kLockGroupsPerTask = 8;

// Clusters per task of count_level_edges' counts (count_cluster_edges, with vertex placement:
// ~13 µs per cluster on the 1M sphere at one thread), so a task is ~1 ms against a wake-up of
// the pool.
constexpr size_t kCountEdgesClustersPerTask = 64;

// Groups and clusters per task of combine_level's passes: ~100 µs of work per task (a group's
// spheres ~0.9 µs, its new clusters ~0.7 µs; a cluster's lock reset ~0.2 µs: the 1M sphere,
// one thread), so the levels whose passes take less than a wake-up of the pool's threads
// (~0.05-1 ms on a 2-vCPU VM, docs/acceptance/issue23_group39.md) run them on one task, in
// order, on the calling thread: the 1M sphere's levels 3-13 of the groups' passes.
constexpr size_t kCombineGroupsPerTask = 128;
constexpr size_t kCombineClustersPerTask = 512;

// Clusters per task of the layout's passes (lay_out): ~128 triangles each, so ~50 µs of work
// per task against ~1 µs of hand-out, and a 64k-cluster DAG (the 4M sphere) gives 256 tasks
// to balance.
constexpr size_t kLayoutClustersPerTask = 256;

// Fresh heap memory a thread fills in a leaf pass of several chunks (LeafTasks::plan), advised
// for huge pages on each thread first (advise_thread_heap): a pool thread's heap is an arena of
// its own, never advised, and the main heap is advised only below its first step, so the
// grower's arrays and the leaves' triangle sets were faulted in 4 KiB at a time. The 1M sphere
// at two threads: the pool thread's first chunk (~131k triangles) took 2,096 faults (~8.2 MiB:
// ~64 bytes per triangle, the grower's per-triangle and per-vertex arrays) and 62-70 CPU-ms
// against 38 on one thread; the leaf pass 6,100 faults at two threads, 3,100 at one
// (docs/acceptance/issue23_big41.md). The leaves' sets hold 16 bytes per triangle (3 corners, a
// material), a thread's share of them: the mesh's triangles over the pool's threads (the 4M
// sphere: ~40 MB a thread). Advice costs address space only; pages become resident as they
// are touched, a huge page at a time.
constexpr size_t kGrowerHeapBytesPerTriangle = 64;
constexpr size_t kLeafSetBytesPerTriangle = 16;

// Cluster records reserved per leaf cluster for the whole DAG (build_leaves): the levels add
// about as many as the leaves (the spheres and 6 of the 8 corpus meshes: 2.03x to 2.13x;
// elephant-with-holes 2.31x, blade 2.86x, where groups that cannot simplify keep adding
// levels); a DAG that needs more grows the array as a vector does.
constexpr double kReservedClustersPerLeaf = 2.25;

// AABB of the vertices referenced by triangles, by fixed blocks combined in order (as the pool's
// blocks were: the same box, -0.0 and +0.0 included); on one thread, beside the weld (prepare).
Aabb indexed_bounds(const Mesh& mesh) {
  const size_t n = mesh.triangle_count();
  Aabb box;
  for (size_t begin = 0; begin < n; begin += kTrianglesPerTask) {
    Aabb part;
    for (size_t i = 3 * begin; i < 3 * std::min(n, begin + kTrianglesPerTask); ++i)
      part.extend(mesh.position(mesh.indices[i]));
    box.extend(part);
  }
  return box;
}

// `degenerate` (per mesh triangle) is cut the same way into `chunk_degenerate`. `released`:
// the mesh's own indices when its owner gave them up (BuildState::released_indices): the one
// chunk takes them instead of a copy. Several chunks leave them be: freeing the 1M sphere's
// (12 MB) once cut raised its peak by 0.3 MiB (the levels' arrays then land elsewhere).
std::vector<TriangleSet> leaf_chunks(const Mesh& mesh, const Aabb& box, ThreadPool& pool,
                                     const std::vector<uint8_t>& degenerate,
                                     std::vector<std::vector<uint8_t>>& chunk_degenerate,
                                     std::vector<uint32_t>* released) {
  size_t n = mesh.triangle_count();
  std::vector<TriangleSet> chunks;
  if (n <= kLeafChunkTriangles) {
    TriangleSet all;
    if (released)
      all.corners = std::move(*released);
    else
      all.corners = mesh.indices;
    all.materials.resize(n);
    for (size_t t = 0; t < n; ++t) all.materials[t] = mesh.material(t);
    chunks.push_back(std::move(all));
    chunk_degenerate = {degenerate};
    return chunks;
  }
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
    return morton_code(q[2], q[1], q[0]);  // z in the lowest bit of each triple
  };
  // A counting sort by cell, stable (triangle order within a cell), in parallel: per task a
  // histogram, then each (cell, task) range starts after the cell's earlier tasks' ranges, so
  // the order is the serial sort's on any thread count.
  constexpr size_t kCellCount = size_t(kCells) * kCells * kCells;
  const size_t tasks = (n + kTrianglesPerTask - 1) / kTrianglesPerTask;
  // `cell` and `order` are written whole by the parallel passes: left uninitialized (a vector's
  // zero fill of their 6 MB on the 1M sphere ran on one thread before them).
  const std::unique_ptr<uint16_t[]> cell(new uint16_t[n]);
  advise_huge_pages(cell.get(), n * sizeof(uint16_t));
  std::vector<uint32_t> task_count(tasks * kCellCount, 0);  // [task][cell]
  pool.parallel_for(tasks, [&](size_t k) {
    uint32_t* histogram = &task_count[k * kCellCount];
    for (size_t t = k * kTrianglesPerTask; t < std::min(n, (k + 1) * kTrianglesPerTask); ++t) {
      cell[t] = uint16_t(cell_of(t));
      ++histogram[cell[t]];
    }
  });
  std::vector<size_t> count(kCellCount + 1, 0);  // count[c] = first position of cell c
  std::vector<size_t> task_fill(tasks * kCellCount);
  for (size_t c = 0, at = 0; c < kCellCount; ++c) {
    count[c] = at;
    for (size_t k = 0; k < tasks; ++k) task_fill[k * kCellCount + c] = at, at += task_count[k * kCellCount + c];
  }
  count[kCellCount] = n;
  const std::unique_ptr<uint32_t[]> order(new uint32_t[n]);
  advise_huge_pages(order.get(), n * sizeof(uint32_t));
  pool.parallel_for(tasks, [&](size_t k) {
    size_t* fill = &task_fill[k * kCellCount];
    for (size_t t = k * kTrianglesPerTask; t < std::min(n, (k + 1) * kTrianglesPerTask); ++t) order[fill[cell[t]]++] = uint32_t(t);
  });
  // Chunk = consecutive cells until it reaches kLeafChunkTriangles: ranges of `order`.
  std::vector<std::pair<size_t, size_t>> ranges;
  size_t begin = 0;
  for (size_t c = 0; c + 1 < count.size(); ++c)
    if (count[c + 1] - begin >= kLeafChunkTriangles) {
      ranges.push_back({begin, count[c + 1]});
      begin = count[c + 1];
    }
  if (begin < n) ranges.push_back({begin, n});
  chunks.resize(ranges.size());
  chunk_degenerate.resize(ranges.size());
  pool.parallel_for(ranges.size(), [&](size_t k) {
    TriangleSet& chunk = chunks[k];
    chunk.corners.reserve(3 * (ranges[k].second - ranges[k].first));
    chunk.materials.reserve(ranges[k].second - ranges[k].first);
    chunk_degenerate[k].reserve(ranges[k].second - ranges[k].first);
    for (size_t i = ranges[k].first; i < ranges[k].second; ++i) {
      uint32_t t = order[i];
      chunk.corners.insert(chunk.corners.end(), &mesh.indices[3 * size_t(t)], &mesh.indices[3 * size_t(t)] + 3);
      chunk.materials.push_back(mesh.material(t));
      chunk_degenerate[k].push_back(degenerate[t]);
    }
  });
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

// Calls fn(edge, begin, end, used_by_several) once per distinct edge of `sorted`, with its uses
// [begin, end); used_by_several: owner(list) differs between two of them.
template <class Owner, class Fn>
void for_each_edge_of_sorted_uses(const SortedEdgeUses& sorted, Owner&& owner, Fn&& fn) {
  const std::vector<KeyedUse>& uses = sorted.uses;
  for (size_t i = 0; i < uses.size();) {
    size_t j = i;
    bool shared = false;
    for (; j < uses.size() && uses[j].key == uses[i].key; ++j) shared |= owner(uses[j].list) != owner(uses[i].list);
    fn(sorted.edge(i), i, j, shared);
    i = j;
  }
}

}  // namespace

// Before any block task runs (spec/dag.md §2.3 Locks): the first block to claim a vertex
// owns it, any other locks it, so `locked` does not depend on the order of the claims.
std::vector<uint64_t> build_detail::lock_cross_block_vertices(const WeldedMesh& welded,
                                                              const std::vector<const TriangleSet*>& clusters,
                                                              const std::vector<uint32_t>& block_of, ThreadPool& pool,
                                                              std::vector<uint32_t>& owner,
                                                              std::vector<uint8_t>& locked,
                                                              const std::vector<const std::vector<uint32_t>*>* vertices) {
  // fn(w) per distinct welded id of cluster i (a vertex's later corners in one cluster decide
  // nothing: its first one claimed or locked it for the same block), else per corner.
  auto for_each_vertex = [&](size_t i, auto&& fn) {
    if (vertices && (*vertices)[i]) {
      for (uint32_t w : *(*vertices)[i]) fn(w);
    } else {
      for (uint32_t v : clusters[i]->corners) fn(welded.weld[v]);
    }
  };
  pool.parallel_for(clusters.size(), [&](size_t i) {
    const uint32_t block = block_of[i];
    for_each_vertex(i, [&](uint32_t w) {
      // An owner, once claimed, never changes: a plain read that finds one decides without the
      // compare-exchange (a locked instruction per corner was most of this pass; a vertex's
      // corners mostly follow its first claim in the same cluster).
      std::atomic_ref<uint32_t> claim(owner[w]);
      uint32_t expected = claim.load(std::memory_order_relaxed);
      if (expected == kNone && claim.compare_exchange_strong(expected, block, std::memory_order_relaxed)) return;
      if (expected != block) {
        std::atomic_ref<uint8_t> lock(locked[w]);
        if (!lock.load(std::memory_order_relaxed)) lock.store(1, std::memory_order_relaxed);
      }
    });
  });
  std::vector<std::vector<uint64_t>> per_cluster(clusters.size());
  pool.parallel_for(clusters.size(), [&](size_t i) {
    const TriangleSet& t = *clusters[i];
    // The claims reset, then for_each_welded_edge's edges with both ends locked (each corner's
    // weld and lock read once).
    for_each_vertex(i, [&](uint32_t x) {
      std::atomic_ref<uint32_t> claim(owner[x]);
      if (claim.load(std::memory_order_relaxed) != kNone) claim.store(kNone, std::memory_order_relaxed);
    });
    for (size_t c = 0; c + 3 <= t.corners.size(); c += 3) {
      const uint32_t w[3] = {welded.weld[t.corners[c]], welded.weld[t.corners[c + 1]], welded.weld[t.corners[c + 2]]};
      const bool l[3] = {locked[w[0]] != 0, locked[w[1]] != 0, locked[w[2]] != 0};
      for (int k = 0; k < 3; ++k) {
        const int next = k == 2 ? 0 : k + 1;
        if (l[k] && l[next] && w[k] != w[next]) per_cluster[i].push_back(edge_key(w[k], w[next]));
      }
    }
  });
  // An edge used by clusters of two blocks is shared.
  std::vector<uint64_t> cross_edges;
  for_each_edge_of_sorted_uses(
      sorted_edge_uses(per_cluster, &pool), [&](uint32_t cluster) { return block_of[cluster]; },
      [&](uint64_t e, size_t, size_t, bool shared) {
        if (shared) cross_edges.push_back(e);
      });
  return cross_edges;
}

namespace {

// ---- build state: what the phases of spec/dag.md §2 share ----

// Per-task scratch arrays (vertex_count entries, kept all-kNone between uses) from a small
// locked free list: parallel_for does not tell a task which worker runs it.
struct ScratchPool {
  size_t size = 0, capacity = 0;  // capacity: reserved for vertices placed later (placement_capacity)
  std::mutex mutex;
  std::vector<std::vector<uint32_t>> free;
  std::vector<uint32_t> take() {
    std::lock_guard<std::mutex> lock(mutex);
    if (free.empty()) {
      std::vector<uint32_t> s;
      // Huge pages: the tasks index it by vertex, all over it (fewer TLB misses, 2 MiB faults).
      reserve_huge_pages(s, std::max(size, capacity));
      s.assign(size, kNone);
      return s;
    }
    std::vector<uint32_t> s = std::move(free.back());
    free.pop_back();
    return s;
  }
  void give(std::vector<uint32_t>&& s) {
    std::lock_guard<std::mutex> lock(mutex);
    free.push_back(std::move(s));
  }
};

// Lock state by welded id (spec/dag.md §2.3 Locks). `retired`/`retired_edges` persist across
// levels; `owner`/`locked` are per level and reset to kNone/0 after it.
struct LockState {
  std::vector<uint8_t> retired;         // welded vertex of a terminal group's member
  std::vector<uint64_t> retired_edges;  // sorted welded edge keys of terminal groups' members
  std::vector<uint32_t> owner;          // block (cross-block pass) or block<<16|group tag
  std::vector<uint8_t> locked;
  std::vector<uint8_t> pinned;  // welded vertex locked at every level (seams, pin_seam_vertices)
  std::vector<uint8_t> mesh_border;  // welded vertex on the mesh's own open edges (pin_seam_vertices)
};

struct BuildState {
  const Mesh& mesh;
  // mesh.indices, when the mesh's owner gave them up (build_scene of a Scene&&): a mesh of one
  // leaf chunk hands them to it (leaf_chunks) instead of a copy, and nothing after the leaf
  // pass reads the mesh's triangles, only its vertices. The copy (armadillo 0.6 MB) then no
  // longer adds to the leaf pass's and the levels' peaks. Null: the caller keeps its mesh whole.
  std::vector<uint32_t>* released_indices = nullptr;
  const BuildOptions& options;
  const InternalBuildOptions& internal;
  ThreadPool pool;
  WeldedMesh welded;
  Aabb mesh_box;  // of the vertices referenced by triangles (leaf chunking, ClusterDag::bounds)
  ScratchPool scratch;
  LockState locks;
  FinSet fins;  // left out of every simplifier input (find_fins)
  std::vector<uint8_t> leaf_degenerate;  // is_degenerate per mesh triangle (find_fins; freed after the leaves)
  std::vector<WorkCluster> clusters;
  std::vector<ClusterFacts> next_facts;  // of the next level's clusters, in their order (empty: none)
  std::vector<WorkGroup> groups;
  LeafSurface leaf_surface;  // the original surface the stored errors are measured against
  BuildReport report;
  // Vertex placement (vertex_placement.cpp): `vertices` holds the positions, normals and uvs of
  // every vertex id, the mesh's and the moved ones appended level by level (combine_level);
  // `positions` points at it once placement runs, else at `mesh`.
  bool placement = false;
  Mesh vertices;
  const Mesh* positions = nullptr;

  BuildState(const Mesh& m, const BuildOptions& o, const InternalBuildOptions& i)
      : mesh(m), options(o), internal(i), pool(o.threads), positions(&m) {}
};

// One level's result of a group task (simplify, border check, split, error).
struct GroupResult {
  bool terminal = true;
  float error = 0.0f;
  std::vector<TriangleSet> clusters;  // corners of moved vertices: their old ids until combine_level
  // Per cluster, when found in the task (no vertex placement): its sphere and facts.
  std::vector<Sphere> bounds;
  std::vector<ClusterFacts> facts;
  VertexMoves moves;
  double seconds_simplify = 0, seconds_split = 0, seconds_error = 0;
};

// A spatial block of one level's active clusters: grouped by its own partition (group_clusters).
struct Block {
  std::vector<uint32_t> items;                // indices into `active`, ascending
  std::vector<std::vector<uint32_t>> groups;  // members as cluster indices
  // Per group: its welded edges also used outside it (shared edges), one entry per use by
  // the group's triangles, sorted: the border check's input (check_simplification).
  std::vector<std::vector<uint64_t>> group_shared_edges;
  std::vector<GroupResult> results;
  double seconds_group = 0, seconds_locks = 0;
};

// State of one level L (spec/dag.md §2.3).
struct LevelState {
  uint32_t level = 0;
  uint32_t first_fresh = 0;  // vertex count at the level's start: the groups' temporary ids of moved vertices
  std::vector<uint32_t> active;                // level-L cluster indices
  // Per active cluster (empty: none): ClusterFacts. The active clusters are consecutive
  // indices (the leaves, then each level's new ones), so cluster m's are facts[m - active[0]].
  std::vector<ClusterFacts> facts;
  BuildLevelReport report;
  std::vector<std::vector<uint64_t>> open_keys;  // per active cluster: open welded edges (grouping)
  bool simplify_allowed = false;               // false: one terminal group (root or kMaxLevels)
  std::vector<Block> blocks;
  std::vector<uint64_t> cross_edges;  // sorted welded edges used by clusters of two blocks
  double seconds_cross = 0;
};

const ClusterFacts* facts_of(const LevelState& L, uint32_t m) {
  return L.facts.empty() ? nullptr : &L.facts[m - L.active.front()];
}

// ---- 1b. seams (spec/dag.md §2.3 Seams) ----
// A seam edge is a mesh-border edge whose two ends each lie within kSeamExtentFraction of the
// ends of another mesh-border edge (one end may be the same vertex): the page format's grid can
// weld the two into one interior edge, so simplifying one side only would open a crack there.
// Its ends are locked at every level. The pass runs where mesh borders simplify: the OpenMesh
// backend, and meshopt with open-border caps (border_caps.cpp; without them meshopt's
// LockBorder keeps mesh borders). Pinning more than needed
// is safe (it only simplifies less), so a crowded search cell pins all of its vertices.
void pin_seam_vertices(BuildState& s) {
  std::vector<uint8_t>& pinned = s.locks.pinned;
  pinned.assign(s.mesh.vertex_count(), 0);
  const bool borders_simplify = s.options.simplifier == Simplifier::kOpenMesh || s.internal.simplify_open_borders;
  if (!borders_simplify || s.mesh_box.empty()) return;
  // A border edge is used once, an odd count: if a hash of every welded edge's key XORs to
  // zero, every edge is used an even number of times (up to a 2^-64 collision, which only
  // keeps the borders locked) and the mesh has no border: closed meshes, most of the large
  // ones, skip the sort below (0.2 CPU-s on the 1M sphere).
  // XOR is order-free: per-task parts combine to the same value on any thread count.
  const size_t triangles = s.mesh.triangle_count(), tasks = (triangles + kTrianglesPerTask - 1) / kTrianglesPerTask;
  std::vector<uint64_t> part(tasks, 0);
  s.pool.parallel_for(tasks, [&](size_t k) {
    const uint32_t* weld = s.welded.weld.data();
    uint64_t x = 0;
    for (size_t t = k * kTrianglesPerTask; t < std::min(triangles, (k + 1) * kTrianglesPerTask); ++t) {
      const uint32_t* c = &s.mesh.indices[3 * t];
      const uint32_t w[3] = {weld[c[0]], weld[c[1]], weld[c[2]]};
      for (int j = 0; j < 3; ++j) {
        const uint32_t a = w[j], b = w[j == 2 ? 0 : j + 1];
        if (a != b) x ^= (edge_key(a, b) + 1) * 0x9E3779B97F4A7C15ull ^ (edge_key(a, b) >> 29);
      }
    }
    part[k] = x;
  });
  uint64_t parity = 0;
  for (uint64_t x : part) parity ^= x;
  if (parity == 0) return;
  std::vector<uint64_t> edges;
  edges.reserve(s.mesh.indices.size());
  for_each_welded_edge(s.welded, s.mesh.indices, [&](uint32_t a, uint32_t b) {
    if (a != b) edges.push_back(edge_key(a, b));
  });
  std::sort(edges.begin(), edges.end());
  std::vector<uint64_t> border_edges;  // welded edges used by exactly one triangle, sorted
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) border_edges.push_back(edges[i]);
    i = j;
  }
  edges = {};
  std::vector<uint32_t> border;  // their welded ends, sorted
  for (uint64_t e : border_edges) border.insert(border.end(), {uint32_t(e >> 32), uint32_t(e)});
  std::sort(border.begin(), border.end());
  border.erase(std::unique(border.begin(), border.end()), border.end());
  if (!border.empty()) {
    s.locks.mesh_border.assign(s.mesh.vertex_count(), 0);
    for (uint32_t w : border) s.locks.mesh_border[w] = 1;
  }
  const Vec3 lo = s.mesh_box.min, hi = s.mesh_box.max;
  const double extent = std::max({double(hi.x) - lo.x, double(hi.y) - lo.y, double(hi.z) - lo.z});
  const double max_abs = std::max({std::fabs(lo.x), std::fabs(lo.y), std::fabs(lo.z), std::fabs(hi.x),
                                   std::fabs(hi.y), std::fabs(hi.z)});
  const double tolerance = std::max(extent * kSeamExtentFraction, double(max_abs) * kSeamMagnitudeFraction);
  if (border.size() < 3 || !(tolerance > 0)) return;
  const float* P = s.mesh.positions.data();
  auto near = [&](uint32_t a, uint32_t b) {
    for (int k = 0; k < 3; ++k)
      if (!(std::fabs(double(P[3 * a + k]) - double(P[3 * b + k])) < tolerance)) return false;
    return true;
  };
  // Near pairs of border vertices. Two coordinates less than `tolerance` apart share a cell
  // of size 2·tolerance in at least one of two partitions shifted by `tolerance`; per axis,
  // so 8 shifted grids find every pair.
  std::vector<std::pair<uint32_t, uint32_t>> pairs;  // (a, b) and (b, a)
  const double cell = 2.0 * tolerance;
  const double origin[3] = {lo.x, lo.y, lo.z};
  std::vector<std::pair<std::array<int64_t, 3>, uint32_t>> keyed(border.size());
  for (uint32_t shift = 0; shift < 8; ++shift) {
    for (size_t i = 0; i < border.size(); ++i) {
      const uint32_t w = border[i];
      for (int k = 0; k < 3; ++k)
        keyed[i].first[k] =
            int64_t(std::floor((double(P[3 * w + k]) - origin[k] + ((shift >> k) & 1) * tolerance) / cell));
      keyed[i].second = w;
    }
    std::sort(keyed.begin(), keyed.end());
    for (size_t i = 0; i < keyed.size();) {
      size_t j = i + 1;
      while (j < keyed.size() && keyed[j].first == keyed[i].first) ++j;
      if (j - i > kSeamCellPairwiseLimit) {
        for (size_t a = i; a < j; ++a) pinned[keyed[a].second] = 1;
      } else {
        for (size_t a = i; a < j; ++a)
          for (size_t b = a + 1; b < j; ++b)
            if (near(keyed[a].second, keyed[b].second)) {
              pairs.push_back({keyed[a].second, keyed[b].second});
              pairs.push_back({keyed[b].second, keyed[a].second});
            }
      }
      i = j;
    }
  }
  if (pairs.empty()) return;
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  // Seam edges: (u, v) with a border edge (u', v') != (u, v), u' = u or near u, v' = v or near v.
  auto partners = [&](uint32_t w, auto&& fn) {
    fn(w);
    auto it = std::lower_bound(pairs.begin(), pairs.end(), std::pair<uint32_t, uint32_t>{w, 0});
    for (; it != pairs.end() && it->first == w; ++it) fn(it->second);
  };
  for (uint64_t e : border_edges) {
    const uint32_t u = uint32_t(e >> 32), v = uint32_t(e);
    bool seam = false;
    partners(u, [&](uint32_t u2) {
      partners(v, [&](uint32_t v2) {
        const uint64_t e2 = edge_key(u2, v2);
        if (!seam && u2 != v2 && e2 != e && std::binary_search(border_edges.begin(), border_edges.end(), e2)) seam = true;
      });
    });
    if (seam) pinned[u] = pinned[v] = 1;
  }
}

// ---- 1. validate, weld ----
// With vertex placement the per-vertex arrays grow level by level (append_moved_vertices):
// they reserve this many vertices up front, so a level's growth copies nothing (reserved pages
// are not resident until used: the 1M sphere's levels peaked 30 MB higher with growing arrays).
// Placed vertices were 0.78 of the mesh's on the 1M sphere; beyond the reserve they grow as
// vectors do.
inline constexpr double kPlacedVertexReserve = 1.0;
size_t placement_capacity(const BuildState& s) {
  return s.placement ? s.mesh.vertex_count() + size_t(kPlacedVertexReserve * double(s.mesh.vertex_count())) : 0;
}

void prepare(BuildState& s) {
  const double t0 = steady_seconds();
  validate_mesh_sizes(s.mesh);
  s.report.input_triangles = s.mesh.triangle_count();
  const size_t vertex_count = s.mesh.vertex_count();
  // The position weld (one thread: first come in vertex order) runs beside the value checks, the
  // lock arrays' first touch and the mesh's box, which do not depend on it (in this order on one
  // thread). Together they take about as long as the weld (1M sphere: 4-6 CPU-ms against 5; with
  // the box on the pool after them, the weld's other thread idled ~3 ms). A check that fails is
  // raised once the weld is done: the same error on any thread count.
  s.pool.parallel_for(2, [&](size_t task) {
    if (task == 1) {
      s.welded = weld_positions(s.mesh);
      return;
    }
    validate_mesh_values(s.mesh);
    reserve_huge_pages(s.locks.retired, vertex_count);
    reserve_huge_pages(s.locks.owner, vertex_count);
    reserve_huge_pages(s.locks.locked, vertex_count);
    s.locks.retired.assign(vertex_count, 0);
    s.locks.owner.assign(vertex_count, kNone);
    s.locks.locked.assign(vertex_count, 0);
    s.mesh_box = indexed_bounds(s.mesh);
  });
  if (const size_t capacity = placement_capacity(s)) {
    s.welded.weld.reserve(capacity);
    s.welded.copies.reserve(capacity);
    for (std::vector<uint8_t>* a : {&s.locks.retired, &s.locks.locked, &s.locks.pinned}) a->reserve(capacity);
    s.locks.owner.reserve(capacity);
    s.scratch.capacity = capacity;
  }
  s.scratch.size = vertex_count;
  pin_seam_vertices(s);
  s.fins = find_fins(s.welded, s.pool, &s.leaf_degenerate);
  s.report.seconds_prepare = steady_seconds() - t0;
}

// ---- 2. leaf clusters ----
// A batch of a chunk's leaves as its split hands them over (ClusterSink), with their facts
// once computed. The grower hands over lists of the chunk's triangles (`ids`, `ends`: as
// ClusterSink::take_lists), and the thread that computes the facts builds the leaves' triangle
// sets from them first; other splits hand over the sets (`leaves` filled).
struct LeafBatch {
  size_t chunk = 0;
  std::vector<uint32_t> ids, ends;
  std::vector<WorkCluster> leaves;
  std::vector<ClusterFacts> facts;
};

// The leaf pass's tasks, run on every pool thread: a chunk's split (the grower, sequential by
// nature: one thread per chunk) and the facts of a batch of its leaves (cluster_facts), which
// the split hands over as it goes, so a free thread computes them beside the grower: those of a
// mesh of one chunk, and of a larger mesh's last chunks, no longer follow their grower on its
// thread. A thread takes a ready batch first (one thread then gives a chunk's leaves their
// facts right after its split, while they are in cache, as before), else the next chunk
// (largest first: the longest split starts first), else waits while a chunk is being split.
// The first chunk is the calling thread's (thread 0): its heap holds the memory that the
// import and the weld freed, so the grower's per-triangle arrays (~6 MB on a 2^17-triangle
// chunk) land on resident pages; a pool thread's heap had to fault them in first (bunny00 at
// two threads, one chunk: the grower's index_triangles took 15-21 CPU-ms when a pool thread
// won the race for the chunk, 3-5 on the calling thread; docs/acceptance/issue23_leaf40.md).
// Batches land in per-chunk slots in order, so the leaves' order does not depend on threads.
// A chunk's triangles are freed once it is split and its last batch has its leaves.
struct LeafTasks {
  explicit LeafTasks(BuildState& state) : s(state) {}
  BuildState& s;
  std::vector<TriangleSet> chunks;  // leaf_chunks; each freed once split and its batches done
  std::vector<std::vector<uint8_t>> chunk_degenerate;
  std::vector<uint32_t> dispatch;  // chunk indices in the order they are handed out
  std::vector<std::vector<std::unique_ptr<LeafBatch>>> batches;  // per chunk, in order
  std::mutex mutex;  // guards what follows and `batches`' lists
  std::condition_variable changed;
  std::deque<LeafBatch*> ready;  // batches without facts, oldest first
  size_t next_chunk = 0, splitting = 0;
  std::vector<uint32_t> unfinished;  // per chunk: its split (1 while running) + batches without facts
  std::exception_ptr first_error;
  size_t heap_bytes = 0;  // advised on each thread before its first task (plan; 0: none)

  void plan();
  void run(unsigned thread);
  void split_chunk(size_t chunk, std::vector<uint32_t>& scratch);
  void publish(size_t chunk, TriangleSet* clusters, size_t count);
  void publish_lists(size_t chunk, const uint32_t* ids, const uint32_t* ends, size_t count);
  void queue(std::unique_ptr<LeafBatch> batch);
  void give_facts(LeafBatch& batch, std::vector<uint32_t>& scratch) const;
  void finish_part(size_t chunk);
};

// Hands a chunk's clusters to LeafTasks::publish.
struct LeafChunkSink final : ClusterSink {
  LeafChunkSink(LeafTasks& t, size_t c) : tasks(t), chunk(c) {}
  LeafTasks& tasks;
  size_t chunk;
  void take(TriangleSet* clusters, size_t count) override { tasks.publish(chunk, clusters, count); }
  void take_lists(const TriangleSet& tris, const uint32_t* ids, const uint32_t* ends, size_t count) override {
    // Lists of the chunk itself, which LeafTasks keeps until their leaves are built; of any
    // other set (none today), built here.
    if (&tris == &tasks.chunks[chunk])
      tasks.publish_lists(chunk, ids, ends, count);
    else
      ClusterSink::take_lists(tris, ids, ends, count);
  }
};

void LeafTasks::plan() {
  dispatch.resize(chunks.size());
  for (uint32_t i = 0; i < dispatch.size(); ++i) dispatch[i] = i;
  std::stable_sort(dispatch.begin(), dispatch.end(), [&](uint32_t a, uint32_t b) {
    return chunks[a].triangle_count() > chunks[b].triangle_count();
  });
  batches.resize(chunks.size());
  unfinished.assign(chunks.size(), 1);
  if (chunks.size() > 1) {
    size_t triangles = 0;
    for (const TriangleSet& chunk : chunks) triangles += chunk.triangle_count();
    heap_bytes = kGrowerHeapBytesPerTriangle * chunks[dispatch.front()].triangle_count() +
                 kLeafSetBytesPerTriangle * triangles / s.pool.size();
  }
}

void LeafTasks::run(unsigned thread) {
  if (heap_bytes) advise_thread_heap(heap_bytes);
  std::vector<uint32_t> scratch = s.scratch.take();
  std::unique_lock<std::mutex> lock(mutex);
  for (;;) {
    std::exception_ptr error;
    if (!ready.empty()) {
      LeafBatch* batch = ready.front();
      ready.pop_front();
      lock.unlock();
      try {
        give_facts(*batch, scratch);
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      finish_part(batch->chunk);
    } else if (next_chunk < dispatch.size() && (next_chunk > 0 || thread == 0)) {
      const size_t chunk = dispatch[next_chunk++];
      ++splitting;
      if (next_chunk == 1) changed.notify_all();  // the next chunks are free to take now
      lock.unlock();
      try {
        split_chunk(chunk, scratch);
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      finish_part(chunk);
      if (--splitting == 0) changed.notify_all();  // the waiting threads may be done
    } else if (splitting == 0 && next_chunk == dispatch.size()) {
      break;
    } else {
      changed.wait(lock);
    }
    if (error && !first_error) first_error = error;
  }
  lock.unlock();
  s.scratch.give(std::move(scratch));
}

void LeafTasks::split_chunk(size_t chunk, std::vector<uint32_t>& scratch) {
  LeafChunkSink sink(*this, chunk);
  split_into_clusters(s.welded, chunks[chunk], scratch, s.internal.leaf_split, chunk_degenerate[chunk].data(), &sink);
  chunk_degenerate[chunk] = {};
}

void LeafTasks::publish(size_t chunk, TriangleSet* clusters, size_t count) {
  auto batch = std::make_unique<LeafBatch>();
  batch->chunk = chunk;
  batch->leaves.resize(count);
  for (size_t k = 0; k < count; ++k) batch->leaves[k].triangles = std::move(clusters[k]);
  queue(std::move(batch));
}

void LeafTasks::publish_lists(size_t chunk, const uint32_t* ids, const uint32_t* ends, size_t count) {
  auto batch = std::make_unique<LeafBatch>();
  batch->chunk = chunk;
  batch->ids.assign(ids, ids + ends[count - 1]);
  batch->ends.assign(ends, ends + count);
  queue(std::move(batch));
}

void LeafTasks::queue(std::unique_ptr<LeafBatch> batch) {
  {
    std::lock_guard<std::mutex> guard(mutex);
    ++unfinished[batch->chunk];
    ready.push_back(batch.get());
    batches[batch->chunk].push_back(std::move(batch));
  }
  changed.notify_one();
}

// Under the lock: chunk's split or one of its batches is done; the last one frees its triangles.
void LeafTasks::finish_part(size_t chunk) {
  if (--unfinished[chunk] == 0) chunks[chunk] = TriangleSet();
}

void LeafTasks::give_facts(LeafBatch& batch, std::vector<uint32_t>& scratch) const {
  if (!batch.ends.empty()) {
    std::vector<TriangleSet> sets;
    sets.reserve(batch.ends.size());
    for (size_t k = 0, begin = 0; k < batch.ends.size(); begin = batch.ends[k++])
      append_cluster(chunks[batch.chunk], &batch.ids[begin], batch.ends[k] - begin, sets);
    batch.leaves.resize(sets.size());
    for (size_t k = 0; k < sets.size(); ++k) batch.leaves[k].triangles = std::move(sets[k]);
    batch.ids = {}, batch.ends = {};
  }
  batch.facts.resize(batch.leaves.size());
  for (size_t k = 0; k < batch.leaves.size(); ++k) {
    WorkCluster& c = batch.leaves[k];
    batch.facts[k] = cluster_facts(s.mesh, s.welded, c.triangles, scratch, c.bounds);
    c.lod_bounds = c.bounds;
  }
}

void build_leaves(BuildState& s) {
  const double t0 = steady_seconds();
  // Large meshes are cut into spatially coherent chunks (cells of a 16^3 grid in Morton
  // order, consecutive cells merged up to kLeafChunkTriangles) clustered in parallel.
  // The chunking depends only on the mesh, so the output does not depend on threads.
  LeafTasks tasks(s);
  tasks.chunks = leaf_chunks(s.mesh, s.mesh_box, s.pool, s.leaf_degenerate, tasks.chunk_degenerate, s.released_indices);
  s.leaf_degenerate = {};
  tasks.plan();
  s.pool.run_on_all([&](unsigned thread) { tasks.run(thread); });
  if (tasks.first_error) std::rethrow_exception(tasks.first_error);
  size_t leaf_count = 0;
  for (const auto& chunk : tasks.batches)
    for (const auto& batch : chunk) leaf_count += batch->leaves.size();
  // Room for the whole DAG's clusters: each level halves its input (kSimplifyTargetRatio), so
  // the DAG holds about twice the leaves (4M sphere: 2.05x); growing as a vector moved every
  // cluster record into fresh memory at the levels that crossed the capacity.
  reserve_huge_pages(s.clusters, size_t(kReservedClustersPerLeaf * double(leaf_count)));
  s.next_facts.reserve(leaf_count);
  for (const auto& chunk : tasks.batches)
    for (const auto& batch : chunk)
      for (size_t k = 0; k < batch->leaves.size(); ++k) {
        s.clusters.push_back(std::move(batch->leaves[k]));
        s.next_facts.push_back(std::move(batch->facts[k]));
      }
  tasks.batches.clear();
  s.report.seconds_cluster = steady_seconds() - t0;
  const double te = steady_seconds();
  std::vector<const TriangleSet*> leaf_sets(s.clusters.size());
  for (size_t i = 0; i < s.clusters.size(); ++i) leaf_sets[i] = &s.clusters[i].triangles;
  s.leaf_surface = build_leaf_surface(s.welded, leaf_sets, s.pool, s.placement);
  s.report.seconds_error += steady_seconds() - te;
  // A mesh of one chunk (or none: split in place) peaked in its grower's per-triangle arrays;
  // the later phases allocate less but fault in their code: returning the freed pages
  // keeps that code off this peak (armadillo -0.4 MiB). The leaf surface is built first, in
  // those freed pages: trimmed before it, its arrays were faulted in again, ~3-4 ms on the
  // calling thread alone before its first parallel pass (bunny00,
  // docs/acceptance/issue23_leaf40.md). Several chunks reuse each other's memory, and the
  // levels reuse it: no gain there, only page faults (1M sphere: same peak, +2,900 faults).
  if (tasks.chunks.size() <= 1) release_free_heap();
  if (s.placement) {
    // From here on positions are read by id through `vertices` (the leaf tree keeps the mesh's).
    const size_t capacity = placement_capacity(s);
    s.vertices.positions.reserve(3 * capacity);
    s.vertices.positions = s.mesh.positions;
    if (!s.mesh.normals.empty()) s.vertices.normals.reserve(3 * capacity);
    s.vertices.normals = s.mesh.normals;
    if (!s.mesh.uvs.empty()) s.vertices.uvs.reserve(2 * capacity);
    s.vertices.uvs = s.mesh.uvs;
    if (!s.locks.mesh_border.empty()) s.locks.mesh_border.reserve(capacity);
    s.leaf_surface.moved_origin.reserve(capacity - s.mesh.vertex_count());
    s.positions = &s.vertices;
    s.welded.mesh = &s.vertices;
  }
}

// ---- 3a. level edges: per-cluster open edges (grouping) and the level's report ----
void count_level_edges(BuildState& s, LevelState& L) {
  const double t0 = steady_seconds();
  const std::vector<uint32_t>& active = L.active;
  L.report.level = L.level;
  L.report.clusters = active.size();
  std::vector<uint64_t> open(active.size()), all(active.size());
  L.open_keys.assign(active.size(), {});
  // Clusters whose facts were counted when they were made only hand them over (the 1M sphere's
  // 14 levels: ~1 ms at one thread, less than the pool's wake-ups): on this thread, then.
  const bool all_counted =
      !L.facts.empty() && std::all_of(L.facts.begin(), L.facts.end(), [](const ClusterFacts& f) { return f.counted; });
  for_chunks(all_counted ? nullptr : &s.pool, active.size(), kCountEdgesClustersPerTask, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (L.facts.empty() || !L.facts[i].counted) {
        count_cluster_edges(s.welded, s.clusters[active[i]].triangles, &open[i], &all[i], &L.open_keys[i]);
        continue;
      }
      ClusterFacts& f = L.facts[i];
      open[i] = f.open, all[i] = f.all;
      L.open_keys[i] = std::move(f.open_keys);
      f.open_keys = {};
    }
  });
  uint64_t so = 0, sa = 0;
  for (size_t i = 0; i < active.size(); ++i) {
    so += open[i];
    sa += all[i];
    L.report.triangles += s.clusters[active[i]].triangles.triangle_count();
  }
  L.report.boundary_edge_fraction = sa ? double(so) / double(sa) : 0.0;
  L.report.average_fill = double(L.report.triangles) / double(active.size()) / kMaxClusterTriangles;
  s.report.seconds_edges += steady_seconds() - t0;
}

// ---- 3b. blocks, and the locks/edges of vertices used by two blocks ----
// Groups never span blocks, so a vertex used by two blocks is used by two groups and is
// locked up front; every other vertex belongs to one block, whose task decides it.
void plan_blocks(BuildState& s, LevelState& L) {
  const double t0 = steady_seconds();
  const std::vector<uint32_t>& active = L.active;
  const bool last_level = L.level + 1 >= kMaxLevels;
  L.simplify_allowed = !(active.size() == 1 || last_level);
  if (!L.simplify_allowed) {
    L.blocks.resize(1);
    if (active.size() > 1) L.blocks[0].groups = {active};
    else L.blocks[0].groups = {{active[0]}};
    L.blocks[0].results.resize(L.blocks[0].groups.size());
  } else {
    std::vector<Vec3> centres(active.size());
    for (size_t i = 0; i < active.size(); ++i) centres[i] = s.clusters[active[i]].bounds.center;
    std::vector<std::vector<uint32_t>> items = spatial_blocks(centres, s.internal.group_block_clusters);
    L.blocks.resize(items.size());
    for (size_t b = 0; b < items.size(); ++b) L.blocks[b].items = std::move(items[b]);
  }
  const size_t block_count = L.blocks.size();
  assert(block_count < (size_t(1) << 16));
  if (block_count > 1) {
    std::vector<uint32_t> block_of(active.size());
    for (size_t b = 0; b < block_count; ++b)
      for (uint32_t i : L.blocks[b].items) block_of[i] = uint32_t(b);
    std::vector<const TriangleSet*> sets(active.size());
    std::vector<const std::vector<uint32_t>*> vertices(active.size());
    for (size_t i = 0; i < active.size(); ++i) {
      sets[i] = &s.clusters[active[i]].triangles;
      vertices[i] = L.facts.empty() || L.facts[i].welded.empty() ? nullptr : &L.facts[i].welded;
    }
    L.cross_edges =
        lock_cross_block_vertices(s.welded, sets, block_of, s.pool, s.locks.owner, s.locks.locked, &vertices);
  }
  L.seconds_cross = steady_seconds() - t0;
}

// ---- 3c. block task: grouping (group_clusters), then the locks and shared edges of the block ----
// (its own vertices only: cross-block ones are locked already, so tasks never race).
// `inner`: a pool for the locks and shared edges when the block runs alone (a level of one
// block: nothing else is ready, so the other threads would wait), else null (in order). The
// claims are first-come as in lock_cross_block_vertices, so `locked` (a vertex used by two
// groups, a retired or a pinned one) and the edges do not depend on the threads.
void group_and_lock_block(BuildState& s, LevelState& L, size_t b, ThreadPool* inner) {
  Block& blk = L.blocks[b];
  const double tb = steady_seconds();
  {
    const size_t n = blk.items.size();
    std::vector<const TriangleSet*> sets(n);
    std::vector<Sphere> bounds(n);
    std::vector<std::vector<uint64_t>> keys(n);
    for (size_t i = 0; i < n; ++i) {
      sets[i] = &s.clusters[L.active[blk.items[i]]].triangles;
      bounds[i] = s.clusters[L.active[blk.items[i]]].bounds;
      keys[i] = std::move(L.open_keys[blk.items[i]]);
    }
    const uint32_t target = s.internal.group_target_clusters ? s.internal.group_target_clusters
                                                             : default_group_target_clusters(s.options.simplifier);
    blk.groups = group_clusters(sets, keys, bounds, target, s.internal.group_method, inner);
    for (auto& g : blk.groups)
      for (uint32_t& m : g) m = L.active[blk.items[m]];
  }
  const double tl = steady_seconds();
  blk.seconds_group = tl - tb;
  std::vector<uint32_t>& owner = s.locks.owner;
  std::vector<uint8_t>& locked = s.locks.locked;
  const size_t group_count = blk.groups.size();
  // Locks: welded vertices used by two groups of this level, or by a retired cluster.
  for_chunks(inner, group_count, kLockGroupsPerTask, [&](size_t begin, size_t end) {
    for (size_t g = begin; g < end; ++g) {
      const uint32_t tag = uint32_t(b << 16 | g);
      for (uint32_t m : blk.groups[g])
        for_each_cluster_vertex(s.welded, s.clusters[m], facts_of(L, m), [&](uint32_t w) {
          std::atomic_ref<uint8_t> lock(locked[w]);
          if (lock.load(std::memory_order_relaxed)) return;
          // A plain read decides once the vertex is claimed (a vertex of the group's clusters
          // mostly follows its first claim in the same group): the compare-exchange runs once
          // per vertex. A vertex this group claimed was neither retired nor pinned (those are
          // locked, never claimed, and neither changes during the pass), so it stops here.
          std::atomic_ref<uint32_t> claim(owner[w]);
          uint32_t expected = claim.load(std::memory_order_relaxed);
          if (expected == tag) return;
          if (s.locks.retired[w] || s.locks.pinned[w]) {
            lock.store(1, std::memory_order_relaxed);
            return;
          }
          if (expected == kNone && claim.compare_exchange_strong(expected, tag, std::memory_order_relaxed)) return;
          if (expected != tag) lock.store(1, std::memory_order_relaxed);
        });
    }
  });
  // Shared edges: welded edges with both ends locked used by two groups of this level, by
  // two blocks, or by a retired cluster (only those must survive; few: they lie on group
  // borders). Listed per group with one entry per use (a candidate is one use of an edge by a
  // triangle of the group), so the border check needs no search of the block's edges; the
  // locks of this block's vertices are final here (other blocks lock only their own).
  // Collected per group (in parallel with `inner`), then sorted by edge, then group (the
  // same order for any thread count: sorted_edge_uses).
  std::vector<std::vector<uint64_t>> group_candidates(group_count);
  for_chunks(inner, group_count, kLockGroupsPerTask, [&](size_t begin, size_t end) {
    for (size_t g = begin; g < end; ++g)
      for (uint32_t m : blk.groups[g]) {
        const std::vector<uint32_t>& corners = s.clusters[m].triangles.corners;
        // for_each_welded_edge's edges, each corner's weld and lock read once.
        for (size_t c = 0; c + 3 <= corners.size(); c += 3) {
          const uint32_t w[3] = {s.welded.weld[corners[c]], s.welded.weld[corners[c + 1]],
                                 s.welded.weld[corners[c + 2]]};
          const bool l[3] = {locked[w[0]] != 0, locked[w[1]] != 0, locked[w[2]] != 0};
          for (int k = 0; k < 3; ++k) {
            const int next = k == 2 ? 0 : k + 1;
            if (l[k] && l[next] && w[k] != w[next]) group_candidates[g].push_back(edge_key(w[k], w[next]));
          }
        }
      }
  });
  const SortedEdgeUses candidates = sorted_edge_uses(group_candidates, inner);
  group_candidates = {};
  const std::vector<uint64_t>& retired_edges = s.locks.retired_edges;
  blk.group_shared_edges.resize(blk.groups.size());
  for_each_edge_of_sorted_uses(
      candidates, [](uint32_t group) { return group; },
      [&](uint64_t e, size_t begin, size_t end, bool shared) {
        if (shared || std::binary_search(retired_edges.begin(), retired_edges.end(), e) ||
            std::binary_search(L.cross_edges.begin(), L.cross_edges.end(), e))
          for (size_t use = begin; use < end; ++use) blk.group_shared_edges[candidates.uses[use].list].push_back(e);
      });
  blk.results.resize(blk.groups.size());
  blk.seconds_locks = steady_seconds() - tl;
}

// ---- 3d. group task: simplify, check the border, split, measure the error ----
// Corners of moved vertices (moves.vertex[i]) become first + i. `scratch` (vertex-indexed, all
// kNone) is returned in that state.
void rename_moved(const VertexMoves& moves, uint32_t first, std::vector<uint32_t>& scratch, std::vector<uint32_t>& corners) {
  for (size_t i = 0; i < moves.vertex.size(); ++i) scratch[moves.vertex[i]] = first + uint32_t(i);
  for (uint32_t& v : corners)
    if (scratch[v] != kNone) v = scratch[v];
  for (uint32_t v : moves.vertex) scratch[v] = kNone;
}

// At least kMinReduction of the group's triangles removed (and some left).
bool reduces_enough(const TriangleSet& before, const TriangleSet& after) {
  return after.triangle_count() > 0 &&
         double(after.triangle_count()) <= double(before.triangle_count()) * (1.0 - kMinReduction);
}

// A group's simplification whose locked border is kept (or, as the last resort, only folded
// over): false when no attempt reduced enough with the border intact. Every attempt
// simplifies the same prepared input (prepare_group); `scratch` (weld.size() entries, all
// kNone) is returned in that state.
bool simplify_sealed(BuildState& s, const std::vector<uint64_t>& shared_edges, const PreparedGroup& prepared,
                     SimplifyTarget target, std::vector<uint32_t>& scratch, SimplifyResult& simplified) {
  const TriangleSet& merged = *prepared.group;
  SimplifyResult folded_over_border;
  bool sealed = false, have_folded = false;
  // A result that breaks the border or folds over it is retried with fewer collapses (a fold
  // comes from a late collapse next to the locked border); one whose error budget stopped it
  // short of kMinReduction once more without the budget (the budget must not stall a group).
  // A result whose only defect is a border edge used 3 times (parity kept, no crack) is kept
  // as the last resort: a fold over the border is better than a stuck group.
  for (size_t attempt = 0; attempt <= kBorderRetryRatios.size() && !sealed; ++attempt) {
    if (attempt > 0) target.ratio = std::max(target.ratio, kBorderRetryRatios[attempt - 1]);
    simplified = simplify_prepared(s.welded, prepared, s.locks.locked, s.options.simplifier, target, scratch);
    if (!reduces_enough(merged, simplified.triangles) && std::isfinite(target.max_error)) {
      target.max_error = std::numeric_limits<float>::infinity();
      simplified = simplify_prepared(s.welded, prepared, s.locks.locked, s.options.simplifier, target, scratch);
    }
    if (!reduces_enough(merged, simplified.triangles)) break;
    const SimplificationCheck check =
        check_simplification(s.welded, merged, simplified.triangles, prepared.group_locked,
                             simplified.group_locked_kept, shared_edges, scratch);
    const BorderState border = check.border;
    if (border == BorderState::kBroken || check.folds) continue;
    sealed = border == BorderState::kKept;
    if (!sealed && !have_folded) folded_over_border = simplified, have_folded = true;
  }
  if (!sealed && have_folded) simplified = std::move(folded_over_border), sealed = true;
  return sealed;
}

// A group's error with edge flips (spec/dag.md §3, edge flips): its measured error as
// collapsed, then flips where they can lower it, kept only where they did. Flips that leave
// the group's error where it was change nothing a cut is chosen by, but they change the next
// level's input, and there they cost as often as they gain (lion: flips on level 1 left every
// level-1 group's error as it was, and the level-2 group that covers half the mesh measured
// 0.0088 instead of 0.0042: dagq 1.03 -> 1.13 of the peer's). So the measurement hands the
// flips its peak (the lattice point farthest from the leaves): unless a flip changes it, the
// flipped surface keeps that point and its error, and nothing is flipped (no flip pass for a
// group at its floor, none beyond the peak's edges where they do not flip). Otherwise the
// flipped surface's error is measured from the changed triangles and the record of the
// others (leaf_deviation_after_change: the same value a full measurement gives), and the
// flips are kept when it is lower. Either way the stored error is the measured one of the
// triangles kept: stored ≥ measured exactly. `pool` (null: none): the measurements run in
// pieces on it (leaf_deviation), and the flips test their candidates on it.
float measure_with_edge_flips(const BuildState& s, const TriangleSet& input, float floor, TriangleSet& triangles,
                              ThreadPool* pool) {
  // The first simplification of the leaves (floor 0) is never flipped (flip_edges_towards_leaves):
  // no peak or record to keep (half the groups).
  if (!(floor > 0)) return leaf_deviation(s.leaf_surface, *s.positions, input, triangles, floor, nullptr, nullptr, nullptr, pool);
  LatticePeak peak;
  LatticeRecord record;
  const float error = leaf_deviation(s.leaf_surface, *s.positions, input, triangles, floor, &peak, &record, nullptr, pool);
  std::vector<uint8_t> changed;
  TriangleSet flipped = triangles;
  if (!flip_edges_towards_leaves(s.welded, s.leaf_surface, s.locks.locked, floor, peak, record, flipped, changed, nullptr,
                                 pool))
    return error;
  const float flipped_error =
      leaf_deviation_after_change(s.leaf_surface, *s.positions, input, flipped, changed, record, floor, nullptr, pool);
  if (!(flipped_error < error)) return error;
  triangles = std::move(flipped);
  return flipped_error;
}

// The group's error with its vertices placed (vertex_placement.cpp): `moves` gets the moves
// of `triangles`' movable vertices, measured with temporary ids (L.first_fresh on, in the
// order of their final ids, combine_level's, so the lattice points are those of the final ids).
// With `flips`, edges are then flipped on the placed surface as measure_with_edge_flips does on
// the collapsed one, from the one measurement of the placed surface (its peak and record), and
// kept where they lower its error; `triangles` gets the flips kept (old ids). `pool`: as
// measure_with_edge_flips'.
float measure_placed(const BuildState& s, const LevelState& L, const TriangleSet& input, float floor,
                     TriangleSet& triangles, bool flips, std::vector<uint32_t>& scratch, VertexMoves& moves,
                     ThreadPool* pool) {
  PlacementContext ctx;
  ctx.welded = &s.welded;
  ctx.mesh = s.positions;
  ctx.leaf_positions = s.mesh.positions.data();
  ctx.leaves = &s.leaf_surface;
  ctx.locked = &s.locks.locked;
  ctx.pinned = &s.locks.pinned;
  ctx.mesh_border = &s.locks.mesh_border;
  ctx.share = s.internal.placement_share;
  moves = place_vertices(ctx, triangles, scratch);
  if (moves.vertex.empty())
    return flips ? measure_with_edge_flips(s, input, floor, triangles, pool)
                 : leaf_deviation(s.leaf_surface, *s.positions, input, triangles, floor, nullptr, nullptr, nullptr, pool);
  TriangleSet renamed = triangles;
  rename_moved(moves, L.first_fresh, scratch, renamed.corners);
  std::vector<uint32_t> origin(moves.vertex.size());
  for (size_t i = 0; i < origin.size(); ++i) origin[i] = s.leaf_surface.origin(moves.vertex[i]);
  const FreshVertices fresh{L.first_fresh, uint32_t(moves.vertex.size()), moves.positions.data(), origin.data(),
                            moves.vertex.data()};
  // No flips at floor 0, as measure_with_edge_flips.
  if (!flips || !(floor > 0))
    return leaf_deviation(s.leaf_surface, *s.positions, input, renamed, floor, nullptr, nullptr, &fresh, pool);
  LatticePeak peak;
  LatticeRecord record;
  const float error = leaf_deviation(s.leaf_surface, *s.positions, input, renamed, floor, &peak, &record, &fresh);
  if (peak.triangle == kNone || peak.corner) return error;  // nothing a flip can lower (flip_edges_towards_leaves)
  std::vector<uint8_t> changed;
  TriangleSet flipped = renamed;
  if (!flip_edges_towards_leaves(s.welded, s.leaf_surface, s.locks.locked, floor, peak, record, flipped, changed, &fresh,
                                 pool))
    return error;
  const float flipped_error =
      leaf_deviation_after_change(s.leaf_surface, *s.positions, input, flipped, changed, record, floor, &fresh, pool);
  if (!(flipped_error < error)) return error;
  for (size_t k = 0; k < flipped.corners.size(); ++k) {
    const uint32_t v = flipped.corners[k];
    triangles.corners[k] = v >= L.first_fresh ? moves.vertex[v - L.first_fresh] : v;
  }
  return flipped_error;
}

// `measure_pool` (null: none): a pool whose threads are idle while this group runs (it runs
// alone: run_lone_block), on which its error measurements run in pieces.
void simplify_one_group(BuildState& s, LevelState& L, size_t b, size_t g, ThreadPool* measure_pool) {
  const Block& blk = L.blocks[b];
  GroupResult& r = L.blocks[b].results[g];
  const double ts = steady_seconds();
  double seconds_error = 0;  // in leaf_deviation: the report shows it apart from the simplification
  TriangleSet merged;
  size_t merged_triangles = 0;
  for (uint32_t m : blk.groups[g]) merged_triangles += s.clusters[m].triangles.triangle_count();
  merged.corners.reserve(3 * merged_triangles);
  merged.materials.reserve(merged_triangles);
  for (uint32_t m : blk.groups[g]) {
    const TriangleSet& t = s.clusters[m].triangles;
    merged.corners.insert(merged.corners.end(), t.corners.begin(), t.corners.end());
    merged.materials.insert(merged.materials.end(), t.materials.begin(), t.materials.end());
  }
  float max_member_error = 0.0f;
  for (uint32_t m : blk.groups[g]) max_member_error = std::max(max_member_error, s.clusters[m].lod_error);
  SimplifyTarget target;
  target.ratio = s.internal.simplify_target_ratio;
  target.open_borders = s.internal.simplify_open_borders;
  if (!s.locks.mesh_border.empty()) target.mesh_border = &s.locks.mesh_border;
  if (s.internal.simplify_error_budget > 0 && max_member_error > 0)
    target.max_error = s.internal.simplify_error_budget * max_member_error;
  std::vector<uint32_t> scratch = s.scratch.take();
  const PreparedGroup prepared = prepare_group(s.welded, merged, s.locks.locked, s.options.simplifier, s.fins,
                                               target.open_borders ? target.mesh_border : nullptr, scratch);
  SimplifyResult simplified;
  bool sealed = simplify_sealed(s, blk.group_shared_edges[g], prepared, target, scratch, simplified);
  if (!sealed && target.mesh_border && target.open_borders && s.options.simplifier == Simplifier::kMeshopt) {
    target.open_borders = false;  // stuck with moving own borders: as before, with them locked
    sealed = simplify_sealed(s, blk.group_shared_edges[g], prepared, target, scratch, simplified);
  }
  float error = 0.0f;
  // The results measured so far as candidates are, before the measurement's flips (only for
  // groups that run candidates: a chain of their own open edges, or caps): a candidate with the
  // same triangles would measure the same error, and a tie never replaces the kept result.
  // The first result is measured as candidates are unless placement flips it.
  std::vector<TriangleSet> measured;
  const bool repeats = s.internal.skip_losing_candidates && sealed &&
                       (simplified.capped || !prepared.open_border.chain_corners.empty());
  if (repeats && !(s.placement && s.options.edge_flips)) measured.push_back(simplified.triangles);
  double tv0 = steady_seconds();
  // The stored error is a promise lib/vgeo/verify checks (ERROR_BOUND): the distance from the
  // simplified surface to the leaves, measured as verify measures it; the members' stored
  // error is a floor (the parent's error takes the max with it anyway).
  // With placement the vertices are placed first, then the flips chosen on the placed surface.
  if (sealed && s.placement)
    error = measure_placed(s, L, merged, max_member_error, simplified.triangles, s.options.edge_flips, scratch, r.moves,
                           measure_pool);
  else if (sealed && s.options.edge_flips)
    error = measure_with_edge_flips(s, merged, max_member_error, simplified.triangles, measure_pool);
  else if (sealed)
    error = leaf_deviation(s.leaf_surface, *s.positions, merged, simplified.triangles, max_member_error, nullptr,
                           nullptr, nullptr, measure_pool);
  seconds_error += steady_seconds() - tv0;
  // A candidate simplification of the group (simplify_sealed with `other`) replaces the kept
  // one when its product of measured error and triangles is smaller (on a surface the error
  // falls about as 1/triangles, so the product compares the two at equal error). It is
  // measured as the first one was, flips included: measured without them, a candidate lost
  // to a flipped first result it would have beaten flipped (mech-holes-shark's one-group
  // level 3: docs/acceptance/issue23_quality2.md). With placement a candidate is placed but
  // not flipped (flipped too, blade's ratio to the peer went 0.720 -> 0.816).
  auto keep_if_better = [&](const SimplifyTarget& other) {
    SimplifyResult alternative;
    if (!simplify_sealed(s, blk.group_shared_edges[g], prepared, other, scratch, alternative)) return;
    if (repeats) {
      for (const TriangleSet& t : measured)
        if (t.corners == alternative.triangles.corners && t.materials == alternative.triangles.materials) return;
      measured.push_back(alternative.triangles);
    }
    tv0 = steady_seconds();
    VertexMoves moves;
    const float alternative_error =
        s.placement
            ? measure_placed(s, L, merged, max_member_error, alternative.triangles, false, scratch, moves, measure_pool)
        : s.options.edge_flips
            ? measure_with_edge_flips(s, merged, max_member_error, alternative.triangles, measure_pool)
            : leaf_deviation(s.leaf_surface, *s.positions, merged, alternative.triangles, max_member_error, nullptr,
                             nullptr, nullptr, measure_pool);
    seconds_error += steady_seconds() - tv0;
    if (double(alternative_error) * double(alternative.triangles.triangle_count()) <
        double(error) * double(simplified.triangles.triangle_count()))
      simplified = std::move(alternative), error = alternative_error, r.moves = std::move(moves);
  };
  // The first result's triangles when it moved the group's own open borders (caps, or a lone
  // group's simplification without LockBorder; 0: it did not).
  const size_t capped_triangles = sealed && simplified.capped ? simplified.triangles.triangle_count() : 0;
  if (sealed && simplified.capped) {
    // The group's own open borders moved (border_caps.cpp). A border collapse can cost more
    // measured error than it saves triangles (a chord across a curved hole): the group is
    // simplified with those borders locked too, and the result with the smaller product of
    // measured error and triangles is kept (on a surface the error falls about as 1/triangles,
    // so the product compares the two at equal error).
    SimplifyTarget locked_target = target;
    locked_target.open_borders = false;
    keep_if_better(locked_target);
    // A lone group was simplified without LockBorder: its capped simplification competes too
    // (lion's coarsest levels: the capped one had the smaller product).
    if (target.lone_unlocked && prepared.input_locked.empty() && !prepared.open_border.chain_corners.empty()) {
      SimplifyTarget capped_target = target;
      capped_target.lone_unlocked = false;
      keep_if_better(capped_target);
    }
  }
  // Caps that keep every loop of the group's own open edges from closing (keep_loops) compete
  // too, whether the plain caps were kept, lost or refused: a hole that closes refuses the
  // group's caps (elephant-with-holes' level-1 groups then kept 70% of their triangles), and
  // where none closes they still place the collapses elsewhere (docs/acceptance/issue23_quality35.md).
  if (sealed && target.open_borders && target.mesh_border && s.options.simplifier == Simplifier::kMeshopt &&
      !prepared.open_border.chain_corners.empty()) {
    SimplifyTarget loops_target = target;
    loops_target.keep_loops = true;
    loops_target.lone_unlocked = false;
    keep_if_better(loops_target);
    // And capped at a milder ratio (kMilderCapsRatio): near the leaves the error falls faster
    // than 1/triangles as collapses are given back, so fewer collapses can win the product
    // (elephant-with-holes: 1.046 -> 0.917 of the peer's triangles at equal measured error;
    // docs/acceptance/issue23_holes36.md). Not where it cannot win (milder_caps_may_win).
    const double kept_product = double(error) * double(simplified.triangles.triangle_count());
    if (s.internal.milder_caps_ratio > target.ratio &&
        (!s.internal.skip_losing_candidates ||
         milder_caps_may_win(double(merged_triangles), double(capped_triangles), kept_product, max_member_error,
                             s.internal.milder_caps_ratio))) {
      SimplifyTarget milder_target = target;
      milder_target.ratio = s.internal.milder_caps_ratio;
      milder_target.lone_unlocked = false;
      keep_if_better(milder_target);
    }
  }
  const double tm = steady_seconds();
  r.seconds_simplify = tm - ts - seconds_error;
  r.seconds_error = seconds_error;
  if (!sealed) {
    s.scratch.give(std::move(scratch));
    return;
  }
  r.clusters = split_into_clusters(s.welded, simplified.triangles, scratch, s.internal.group_split);
  if (!s.placement) {
    r.bounds.resize(r.clusters.size());
    r.facts.resize(r.clusters.size());
    for (size_t i = 0; i < r.clusters.size(); ++i)
      r.facts[i] = cluster_facts(*s.positions, s.welded, r.clusters[i], scratch, r.bounds[i]);
  }
  s.scratch.give(std::move(scratch));
  r.seconds_split = steady_seconds() - tm;
  r.terminal = false;
  r.error = error;
}

// ---- 3e. the level scheduler: one pipelined parallel region per level ----
// A level of one block (every level but the first few of a large mesh: kGroupBlockClusters):
// its grouping runs on one thread, its locks and shared edges on the pool, then its groups:
// as group tasks, except the last (groups mod threads) ones, which would leave threads idle
// while they run (a mesh's last levels: fewer groups than threads, one each at the top; a
// level of 3 groups on 2 threads). Those run one after another after the others, each
// measuring its error on the whole pool (simplify_one_group's measure_pool;
// docs/acceptance/issue23_lone39.md, docs/acceptance/issue23_top40.md).
void run_lone_block(BuildState& s, LevelState& L) {
  group_and_lock_block(s, L, 0, &s.pool);
  const size_t groups = L.blocks[0].groups.size();
  const size_t alone = s.pool.size() > 1 ? groups % s.pool.size() : 0;
  if (groups > alone) s.pool.parallel_for(groups - alone, [&](size_t g) { simplify_one_group(s, L, 0, g, nullptr); });
  for (size_t g = groups - alone; g < groups; ++g) simplify_one_group(s, L, 0, g, &s.pool);
}

// Several blocks: a block task whenever no block task runs or no group task is ready,
// otherwise a ready group task, otherwise wait for a block to finish. While one thread groups a
// block, the others simplify the groups of blocks already grouped.
void run_level(BuildState& s, LevelState& L) {
  const size_t block_count = L.blocks.size();
  if (block_count == 1) return run_lone_block(s, L);
  std::mutex queue_mutex;
  std::condition_variable queue_changed;
  std::vector<std::pair<uint32_t, uint32_t>> ready;  // (block, group), taken from the back
  size_t next_block = 0, blocks_done = 0, blocks_running = 0;
  std::exception_ptr first_error;
  s.pool.run_on_all([&](unsigned) {
    std::unique_lock<std::mutex> lock(queue_mutex);
    for (;;) {
      bool take_block = next_block < block_count && (blocks_running == 0 || ready.empty());
      if (take_block) {
        size_t b = next_block++;
        ++blocks_running;
        lock.unlock();
        try {
          group_and_lock_block(s, L, b, nullptr);
        } catch (...) {
          std::lock_guard<std::mutex> guard(queue_mutex);
          if (!first_error) first_error = std::current_exception();
          L.blocks[b].results.assign(L.blocks[b].groups.size(), GroupResult());
          L.blocks[b].group_shared_edges.assign(L.blocks[b].groups.size(), {});
        }
        lock.lock();
        --blocks_running;
        ++blocks_done;
        for (size_t g = L.blocks[b].groups.size(); g-- > 0;) ready.push_back({uint32_t(b), uint32_t(g)});
        queue_changed.notify_all();
        continue;
      }
      if (!ready.empty()) {
        auto [b, g] = ready.back();
        ready.pop_back();
        lock.unlock();
        try {
          simplify_one_group(s, L, b, g, nullptr);
        } catch (...) {
          std::lock_guard<std::mutex> guard(queue_mutex);
          if (!first_error) first_error = std::current_exception();
        }
        lock.lock();
        continue;
      }
      if (blocks_done == block_count) return;
      queue_changed.wait(lock);
    }
  });
  if (first_error) std::rethrow_exception(first_error);
}

// The pipelined region's wall time, divided between its parts by their summed task times
// (spec/dag.md §4).
void account_level_time(BuildReport& rep, const LevelState& L, double wall) {
  double group = 0, locks = 0, simplify = 0, split = 0, error = 0;
  for (const Block& blk : L.blocks) {
    group += blk.seconds_group;
    locks += blk.seconds_locks;
    for (const GroupResult& r : blk.results) {
      simplify += r.seconds_simplify;
      split += r.seconds_split;
      error += r.seconds_error;
    }
  }
  double sum = group + locks + simplify + split + error;
  rep.seconds_locks += L.seconds_cross;
  if (sum > 0) {
    rep.seconds_group += wall * group / sum;
    rep.seconds_locks += wall * locks / sum;
    rep.seconds_simplify += wall * simplify / sum;
    rep.seconds_split += wall * split / sum;
    rep.seconds_error += wall * error / sum;
  } else {
    rep.seconds_group += wall;
  }
}

// ---- 3f. combine in group order: groups, generated clusters, retired vertices/edges ----
// A group's moved vertices get their ids (the next free ones, in the group's order: as their
// temporary ids were ordered) and every per-vertex array its entries; its clusters' corners
// are renamed.
void append_moved_vertices(BuildState& s, std::vector<GroupResult>& results) {
  size_t added = 0;
  for (const GroupResult& r : results)
    if (!r.terminal) added += r.moves.vertex.size();
  if (added == 0) return;
  Mesh& m = s.vertices;
  const size_t old_count = m.vertex_count(), count = old_count + added;
  if (count >= kNone) fail("BUILD_MESH_TOO_LARGE", s.mesh.name, "more than 2^32-1 vertices with the placed ones");
  m.positions.resize(3 * count);
  if (!m.normals.empty()) m.normals.resize(3 * count);
  if (!m.uvs.empty()) m.uvs.resize(2 * count);
  s.welded.weld.resize(count);
  s.welded.copies.resize(count, 0);
  s.locks.retired.resize(count, 0);
  s.locks.owner.resize(count, kNone);
  s.locks.locked.resize(count, 0);
  s.locks.pinned.resize(count, 0);
  if (!s.locks.mesh_border.empty()) s.locks.mesh_border.resize(count, 0);
  s.leaf_surface.moved_origin.resize(count - s.leaf_surface.leaf_vertex_count);
  std::vector<uint32_t> scratch = s.scratch.take();
  uint32_t first = uint32_t(old_count);
  for (GroupResult& r : results) {
    if (r.terminal || r.moves.vertex.empty()) continue;
    const VertexMoves& moves = r.moves;
    for (size_t i = 0; i < moves.vertex.size(); ++i) {
      const uint32_t v = moves.vertex[i], id = first + uint32_t(i);
      std::memcpy(&m.positions[3 * size_t(id)], &moves.positions[3 * i], 12);
      if (!m.normals.empty()) std::memcpy(&m.normals[3 * size_t(id)], &m.normals[3 * size_t(v)], 12);
      if (!m.uvs.empty()) std::memcpy(&m.uvs[2 * size_t(id)], &m.uvs[2 * size_t(v)], 8);
      // Copies of one old position are consecutive in the moves (place_vertices): the first
      // is the new position's welded id, as weld_positions picks the smallest.
      const bool copy = i > 0 && s.welded.weld[moves.vertex[i - 1]] == s.welded.weld[v];
      const uint32_t rep = copy ? s.welded.weld[id - 1] : id;
      s.welded.weld[id] = rep;
      s.welded.copies[rep] = uint8_t(s.welded.copies[rep] + 1);
      s.leaf_surface.moved_origin[id - s.leaf_surface.leaf_vertex_count] = s.leaf_surface.origin(v);
    }
    for (TriangleSet& t : r.clusters) rename_moved(moves, first, scratch, t.corners);
    first += uint32_t(moves.vertex.size());
    r.moves = VertexMoves();
  }
  s.scratch.give(std::move(scratch));
  s.scratch.size = count;
  for (std::vector<uint32_t>& free : s.scratch.free) free.resize(count, kNone);
}

std::vector<uint32_t> combine_level(BuildState& s, LevelState& L) {
  const double tc = steady_seconds();
  std::vector<GroupResult> results;
  std::vector<std::vector<uint32_t>> level_groups;
  for (Block& blk : L.blocks) {
    for (GroupResult& r : blk.results) results.push_back(std::move(r));
    for (auto& g : blk.groups) level_groups.push_back(std::move(g));
  }
  append_moved_vertices(s, results);
  std::vector<WorkCluster>& clusters = s.clusters;
  std::vector<WorkGroup>& groups = s.groups;
  const uint32_t first_group = uint32_t(groups.size());
  const uint32_t group_count = uint32_t(level_groups.size());
  // The level's groups from their members, on the pool (a cluster is a member of one group);
  // this and the new clusters below ran on one thread, ~0.1 s per 4M-triangle build.
  groups.resize(size_t(first_group) + group_count);
  for_chunks(&s.pool, group_count, kCombineGroupsPerTask, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      WorkGroup& g = groups[first_group + i];
      g.members = std::move(level_groups[i]);
      g.level = L.level;
      uint32_t gi = first_group + uint32_t(i);
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
    }
  });
  L.report.groups = group_count;

  // Each group's new clusters follow the earlier groups' (one thread's appends in group order).
  std::vector<size_t> first_new(size_t(group_count) + 1, clusters.size());
  std::vector<uint64_t> new_retired_edges;
  for (uint32_t i = 0; i < group_count; ++i) {
    GroupResult& r = results[i];
    uint32_t gi = first_group + i;
    first_new[i + 1] = first_new[i];
    if (r.terminal) {
      groups[gi].terminal = true;
      groups[gi].parent_error = kTerminalError;
      ++L.report.stuck_groups;
      for (uint32_t m : groups[gi].members) {
        const TriangleSet& t = clusters[m].triangles;
        for (uint32_t v : t.corners) s.locks.retired[s.welded.weld[v]] = 1;
        for_each_welded_edge(s.welded, t.corners, [&](uint32_t a, uint32_t b) {
          if (a != b) new_retired_edges.push_back(edge_key(a, b));
        });
      }
      continue;
    }
    // parent_error = max(member lod_error, measured deviation from the leaves): monotonic
    // exactly, and tight (no per-level sum).
    if (std::isfinite(r.error)) groups[gi].parent_error = std::max(groups[gi].parent_error, r.error);
    first_new[i + 1] += r.clusters.size();
  }
  if (!L.simplify_allowed) L.report.stuck_groups = 0;  // roots by construction, not stuck
  const size_t old_count = clusters.size(), new_count = first_new[group_count] - old_count;
  clusters.resize(old_count + new_count);
  std::vector<uint32_t> next(new_count);
  std::vector<ClusterFacts> next_facts(new_count);  // (s.next_facts)
  for_chunks(&s.pool, group_count, kCombineGroupsPerTask, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      GroupResult& r = results[i];
      if (r.terminal) continue;
      const uint32_t gi = first_group + uint32_t(i);
      WorkGroup& g = groups[gi];
      g.generated.resize(r.clusters.size());
      for (size_t k = 0; k < r.clusters.size(); ++k) {
        const size_t index = first_new[i] + k;
        WorkCluster& c = clusters[index];
        ClusterFacts& f = next_facts[index - old_count];
        c.triangles = std::move(r.clusters[k]);
        if (!r.facts.empty()) c.bounds = r.bounds[k], f = std::move(r.facts[k]);
        if (!f.counted) c.bounds = cluster_sphere(*s.positions, c.triangles);
        c.level = L.level + 1;
        c.generating_group = gi;
        c.lod_bounds = g.parent_bounds;
        c.lod_error = g.parent_error;
        g.generated[k] = uint32_t(index);
        next[index - old_count] = uint32_t(index);
      }
    }
  });
  // Reset per-level lock state (only the touched entries; the same values from any task).
  for_chunks(&s.pool, L.active.size(), kCombineClustersPerTask, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const ClusterFacts* f = L.facts.empty() ? nullptr : &L.facts[i];
      for_each_cluster_vertex(s.welded, clusters[L.active[i]], f, [&](uint32_t w) {
        std::atomic_ref<uint32_t>(s.locks.owner[w]).store(kNone, std::memory_order_relaxed);
        std::atomic_ref<uint8_t>(s.locks.locked[w]).store(0, std::memory_order_relaxed);
      });
    }
  });
  L.facts = {};
  s.next_facts = std::move(next_facts);
  std::vector<uint64_t>& retired_edges = s.locks.retired_edges;
  if (!new_retired_edges.empty()) {
    retired_edges.insert(retired_edges.end(), new_retired_edges.begin(), new_retired_edges.end());
    std::sort(retired_edges.begin(), retired_edges.end());
    retired_edges.erase(std::unique(retired_edges.begin(), retired_edges.end()), retired_edges.end());
  }
  s.report.seconds_combine += steady_seconds() - tc;
  return next;
}

// ---- 3. per level: edges, blocks, group/lock/simplify/split/error, combine ----
void build_levels(BuildState& s) {
  Progress progress("build", s.report.input_triangles, s.options.progress);
  std::vector<uint32_t> active(s.clusters.size());
  for (size_t i = 0; i < active.size(); ++i) active[i] = uint32_t(i);
  size_t processed = 0;
  for (uint32_t level = 0; !active.empty(); ++level) {
    LevelState L;
    L.level = level;
    L.first_fresh = uint32_t(s.positions->vertex_count());
    L.active = std::move(active);
    // The facts found for these clusters when they were made (ClusterFacts); their indices
    // are consecutive by construction (facts_of).
    L.facts = std::move(s.next_facts);
    s.next_facts = {};
    const bool consecutive = L.active.empty() || L.active.back() - L.active.front() + 1 == L.active.size();
    if (L.facts.size() != L.active.size() || !consecutive) L.facts.clear();
    count_level_edges(s, L);
    plan_blocks(s, L);
    const double region_start = steady_seconds();
    if (L.simplify_allowed) run_level(s, L);
    account_level_time(s.report, L, steady_seconds() - region_start);
    active = combine_level(s, L);
    processed += L.report.triangles;
    progress.set(std::min<size_t>(processed, s.report.input_triangles));
    s.report.levels.push_back(L.report);
  }
}

// Certified mode (BuildOptions::error_bound; spec/dag.md §Error "Certified bound"): the levels
// ran against the measured errors (the simplifier's budget, the border choice), so the clusters
// are the default build's; each group's parent_error becomes max(members' certified error, its
// measured error, a certified bound of its simplified triangles; leaf_certify.cpp), level by
// level (a group's floor is its members'), a level's groups in parallel, each on one thread.
void certify_stored_errors(BuildState& s) {
  const double t0 = steady_seconds();
  const LeafTwins twins = build_leaf_twins(s.leaf_surface, s.welded, s.pool);
  std::vector<WorkGroup>& groups = s.groups;
  std::vector<WorkCluster>& clusters = s.clusters;
  for (size_t first = 0, last = 0; first < groups.size(); first = last) {
    while (last < groups.size() && groups[last].level == groups[first].level) ++last;
    s.pool.parallel_for(last - first, [&](size_t i) {
      WorkGroup& g = groups[first + i];
      if (g.terminal || g.generated.empty()) return;
      float floor = 0.0f;
      for (uint32_t m : g.members) floor = std::max(floor, clusters[m].lod_error);
      std::vector<const TriangleSet*> simplified;
      for (uint32_t c : g.generated) simplified.push_back(&clusters[c].triangles);
      g.parent_error = certified_leaf_deviation(s.leaf_surface, twins, *s.positions, simplified, floor, g.parent_error);
      for (uint32_t c : g.generated) clusters[c].lod_error = g.parent_error;
    });
  }
  s.report.seconds_error += steady_seconds() - t0;
}

// What only the levels needed (the leaf surface, welds, locks, scratch arrays) is freed before
// the layout allocates the DAG's arrays, which then reuse that memory: the build's peak was
// the layout's, with both alive (1M sphere: 146 MiB). The freed pages go back to the kernel
// (release_free_heap, in lay_out beside its record loops, before its large arrays): those arrays
// are smaller than the levels' state, and the layout's and the write's code then no longer add
// to the levels' high-water mark (1M sphere 106.7 -> 102.3 MiB, armadillo -0.3 MiB;
// docs/acceptance/issue23_smallrss.md).
void release_level_state(BuildState& s) {
  s.leaf_surface = LeafSurface();
  s.welded = WeldedMesh();
  s.locks = LockState();
  s.fins = FinSet();
  s.scratch.free = {};
}

// The work clusters' and groups' records (the DAG holds their data once laid out).
void release_work_records(BuildState& s) {
  s.clusters = {};
  s.groups = {};
}

// The layout's order: clusters sorted by group, groups in creation order.
struct LayoutOrder {
  std::vector<uint32_t> new_index;  // work cluster -> DAG cluster
  std::vector<uint32_t> order;      // DAG cluster -> work cluster
  size_t total_triangles = 0;
};

// The group records, the clusters' order and triangle offsets: loops over the records, on one
// thread. Everything they fill is allocated by the caller, so they allocate nothing and run
// beside the heap trim (lay_out) without waiting for malloc's lock.
void lay_out_records(const BuildState& s, ClusterDag& dag, LayoutOrder& o) {
  const std::vector<WorkCluster>& clusters = s.clusters;
  const std::vector<WorkGroup>& groups = s.groups;
  uint32_t next = 0;
  for (const WorkGroup& g : groups)
    for (uint32_t m : g.members) o.new_index[m] = next++;
  assert(next == clusters.size());
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const WorkGroup& w = groups[gi];
    DagGroup& g = dag.groups[gi];
    g.first_cluster = o.new_index[w.members.front()];
    g.cluster_count = uint32_t(w.members.size());
    g.first_generated = uint32_t(dag.generated_clusters.size());
    g.generated_count = uint32_t(w.generated.size());
    for (uint32_t c : w.generated) dag.generated_clusters.push_back(o.new_index[c]);
    g.level = w.level;
    g.flags = w.terminal ? kGroupTerminal : 0u;
    g.bounds = w.bounds;
    g.parent_bounds = w.parent_bounds;
    g.parent_error = w.parent_error;
    dag.level_count = std::max(dag.level_count, w.level + 1);
  }
  // Vertex/triangle offsets need a prefix sum over the final order. The triangles' are known
  // up front, so the local corners are written straight into dag.indices; the vertices' once
  // each cluster's distinct vertices are listed.
  for (size_t i = 0; i < clusters.size(); ++i) o.order[o.new_index[i]] = uint32_t(i);
  for (size_t i = 0; i < clusters.size(); ++i) {
    dag.clusters[i].triangle_offset = uint32_t(o.total_triangles);  // checked by the caller
    o.total_triangles += clusters[o.order[i]].triangles.triangle_count();
  }
}

// ---- 4. layout: groups in creation order (sorted by level), clusters sorted by group ----
ClusterDag lay_out(BuildState& s) {
  const double t0 = steady_seconds();
  const Mesh& mesh = *s.positions;
  const std::vector<WorkCluster>& clusters = s.clusters;
  const std::vector<WorkGroup>& groups = s.groups;
  ThreadPool& pool = s.pool;
  ClusterDag dag;
  LayoutOrder o;
  o.new_index.assign(clusters.size(), kNone);
  o.order.resize(clusters.size());
  dag.groups.resize(groups.size());
  dag.clusters.resize(clusters.size());
  size_t generated = 0;
  for (const WorkGroup& w : groups) generated += w.generated.size();
  dag.generated_clusters.reserve(generated);
  // The levels' freed memory goes back to the kernel (release_level_state) while the records
  // are laid out: the trim was one thread's 2-3 ms on bunny00 and 4-8 ms on the 1M sphere,
  // about as long as the records' loops there. The large arrays below are reserved after it.
  pool.parallel_for(2, [&](size_t k) {
    if (k == 0) lay_out_records(s, dag, o);
    else release_free_heap();
  });
  const std::vector<uint32_t>& order = o.order;
  const size_t total_triangles = o.total_triangles;
  if (total_triangles >= kNone)
    fail("BUILD_MESH_TOO_LARGE", s.mesh.name, "the DAG would exceed 2^32 vertices or triangles");
  // The big arrays are fresh memory: their first touch (page faults, zeroing) is most of
  // the layout's cost. They are reserved, their pages faulted in and written once by equal
  // chunks on every thread (prefault_parallel), and only then sized (the zero fill, one thread
  // per array, then costs a memset).
  dag.indices.reserve(3 * total_triangles);
  dag.triangle_materials.reserve(total_triangles);
  prefault_parallel({{dag.indices.data(), dag.indices.capacity()},
                     {dag.triangle_materials.data(), 4 * dag.triangle_materials.capacity()}},
                    pool);
  pool.parallel_for(2, [&](size_t k) {
    if (k == 0) dag.indices.resize(3 * total_triangles);
    else dag.triangle_materials.resize(total_triangles);
  });
  // Per task of kLayoutClustersPerTask consecutive clusters (final order): their distinct
  // original vertices in order of first use, cluster after cluster (one array per task: two
  // arrays per cluster, their allocations, first touches and frees, were 0.8 of the layout's
  // 1.0 CPU-s on the 4M sphere, and the frees ran on one thread). Each cluster's local corners
  // and materials go straight to their place in the DAG.
  const size_t layout_tasks = (clusters.size() + kLayoutClustersPerTask - 1) / kLayoutClustersPerTask;
  std::vector<std::vector<uint32_t>> task_vertices(layout_tasks);
  pool.parallel_for(layout_tasks, [&](size_t task) {
    std::vector<uint32_t>& verts = task_vertices[task];
    for (size_t i = task * kLayoutClustersPerTask; i < std::min(clusters.size(), (task + 1) * kLayoutClustersPerTask); ++i) {
      const TriangleSet& t = clusters[order[i]].triangles;
      DagCluster& c = dag.clusters[i];
      uint8_t* local = &dag.indices[3 * size_t(c.triangle_offset)];
      const size_t first = verts.size();
      // Open addressing over ≤ 384 corners, ≤ 255 distinct (kMaxClusterVertices): 512 slots, a
      // load ≤ 1/2 (1024 slots cost more to clear per cluster than their shorter probes saved).
      constexpr size_t kSlots = 512;
      constexpr int kSlotShift = 32 - 9;  // top log2(kSlots) bits of the hash
      uint32_t key[kSlots], val[kSlots];
      std::fill(key, key + kSlots, kNone);
      for (size_t k = 0; k < t.corners.size(); ++k) {
        uint32_t v = t.corners[k];
        size_t h = (v * 0x9E3779B1u) >> kSlotShift;
        while (key[h] != kNone && key[h] != v) h = (h + 1) & (kSlots - 1);
        if (key[h] == kNone) {
          key[h] = v;
          val[h] = uint32_t(verts.size() - first);
          verts.push_back(v);
        }
        local[k] = uint8_t(val[h]);
      }
      c.vertex_count = uint32_t(verts.size() - first);
      std::copy(t.materials.begin(), t.materials.end(), dag.triangle_materials.begin() + c.triangle_offset);
    }
  });
  size_t total_vertices = 0;
  for (size_t i = 0; i < clusters.size(); ++i) total_vertices += dag.clusters[i].vertex_count;
  if (total_vertices >= kNone)
    fail("BUILD_MESH_TOO_LARGE", s.mesh.name, "the DAG would exceed 2^32 vertices or triangles");
  dag.positions.reserve(3 * total_vertices);
  if (!mesh.normals.empty()) dag.normals.reserve(3 * total_vertices);
  if (!mesh.uvs.empty()) dag.uvs.reserve(2 * total_vertices);
  prefault_parallel({{dag.positions.data(), 4 * dag.positions.capacity()},
                     {dag.normals.data(), 4 * dag.normals.capacity()},
                     {dag.uvs.data(), 4 * dag.uvs.capacity()}},
                    pool);
  pool.parallel_for(3, [&](size_t k) {
    switch (k) {
      case 0: dag.positions.resize(3 * total_vertices); break;
      case 1: if (!mesh.normals.empty()) dag.normals.resize(3 * total_vertices); break;
      default: if (!mesh.uvs.empty()) dag.uvs.resize(2 * total_vertices); break;
    }
  });
  {
    uint32_t vo = 0;
    for (size_t i = 0; i < clusters.size(); ++i) {
      const WorkCluster& w = clusters[order[i]];
      DagCluster& c = dag.clusters[i];
      c.vertex_offset = vo;
      c.triangle_count = uint32_t(w.triangles.triangle_count());
      c.material_offset = c.triangle_offset;
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
    }
  }
  // Task 0 frees the work records (their last reader was the loop above) beside the copies,
  // instead of after the build on one thread (BuildState's destructor: ~3.5-4.7 ms on the 1M
  // sphere). The copies go by the DAG's cluster count: `clusters` is being freed.
  const size_t cluster_count = dag.clusters.size();
  pool.parallel_for(layout_tasks + 1, [&](size_t k) {
    if (k == 0) {
      release_work_records(s);
      return;
    }
    const size_t task = k - 1;
    const uint32_t* src = task_vertices[task].data();
    for (size_t i = task * kLayoutClustersPerTask; i < std::min(cluster_count, (task + 1) * kLayoutClustersPerTask); ++i) {
      const DagCluster& c = dag.clusters[i];
      for (size_t k = 0; k < c.vertex_count; ++k) {
        size_t dst = c.vertex_offset + k, v = *src++;
        std::memcpy(&dag.positions[3 * dst], &mesh.positions[3 * v], 12);
        if (!dag.normals.empty()) std::memcpy(&dag.normals[3 * dst], &mesh.normals[3 * v], 12);
        if (!dag.uvs.empty()) std::memcpy(&dag.uvs[2 * dst], &mesh.uvs[2 * v], 8);
      }
    }
    task_vertices[task] = {};
  });
  // Only vertices referenced by triangles count as leaf positions.
  dag.bounds = s.mesh_box;
  s.report.seconds_layout = steady_seconds() - t0;
  return dag;
}

// ---- 5. culling hierarchy ----
void build_hierarchy(BuildState& s, ClusterDag& dag) {
  const double t0 = steady_seconds();
  if (!dag.groups.empty()) {
    std::vector<uint32_t> items(dag.groups.size());
    for (size_t i = 0; i < items.size(); ++i) items[i] = uint32_t(i);
    BvhBuilder bvh{dag.groups, dag.bvh_nodes};
    bvh.build(items, 0, items.size());
  }
  s.report.seconds_hierarchy = steady_seconds() - t0;
}

// Totals of spec/dag.md §4 that need the finished DAG.
void finish_report(BuildReport& rep, const ClusterDag& dag, double seconds_total) {
  rep.stored_triangles = dag.triangle_count();
  for (const DagGroup& g : dag.groups)
    if (g.flags & kGroupTerminal) {
      rep.root_clusters += g.cluster_count;
      for (uint32_t c = g.first_cluster; c < g.first_cluster + g.cluster_count; ++c)
        rep.root_triangles += dag.clusters[c].triangle_count;
    }
  rep.seconds_total = seconds_total;
  rep.peak_memory_bytes = peak_rss_bytes();
}

}  // namespace

ClusterDag build_dag(const Mesh& mesh, const BuildOptions& options, BuildReport* report) {
  return build_dag_internal(mesh, options, InternalBuildOptions{}, report);
}

namespace {

// The steps of spec/dag.md §2, in order. `released_indices`: BuildState's.
ClusterDag run_build(const Mesh& mesh, std::vector<uint32_t>* released_indices, const BuildOptions& options,
                     const InternalBuildOptions& internal, BuildReport* report) {
  const double t_start = steady_seconds();
  BuildState s(mesh, options, internal);
  s.released_indices = released_indices;
  s.placement = options.vertex_placement && internal.placement_share > 0;
  prepare(s);
  build_leaves(s);
  build_levels(s);
  if (options.error_bound == ErrorBound::kCertified) certify_stored_errors(s);
  release_level_state(s);
  ClusterDag dag = lay_out(s);
  build_hierarchy(s, dag);
  finish_report(s.report, dag, steady_seconds() - t_start);
  if (report) *report = std::move(s.report);
  return dag;
}

// `owner`: the scene itself when its owner gave it up (build_scene of a Scene&&), else null.
BuiltScene build_each_mesh(const Scene& scene, Scene* owner, const BuildOptions& options,
                           std::vector<BuildReport>* reports) {
  BuiltScene out;
  out.materials = scene.materials;
  out.instances = scene.instances;
  if (reports) reports->clear();
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    BuildReport r;
    std::vector<uint32_t>* released = owner ? &owner->meshes[i].indices : nullptr;
    out.meshes.push_back(run_build(scene.meshes[i], released, options, InternalBuildOptions{}, &r));
    if (reports) reports->push_back(std::move(r));
  }
  return out;
}

}  // namespace

ClusterDag build_detail::build_dag_internal(const Mesh& mesh, const BuildOptions& options,
                                            const InternalBuildOptions& internal, BuildReport* report) {
  return run_build(mesh, nullptr, options, internal, report);
}

BuiltScene build_scene(const Scene& scene, const BuildOptions& options, std::vector<BuildReport>* reports) {
  return build_each_mesh(scene, nullptr, options, reports);
}

BuiltScene build_scene(Scene&& scene, const BuildOptions& options, std::vector<BuildReport>* reports) {
  return build_each_mesh(scene, &scene, options, reports);
}

}  // namespace vgeo
