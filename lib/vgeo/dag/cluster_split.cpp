// Welding, splitting triangle sets into clusters, bounding spheres (spec/dag.md §Build).
#include <meshoptimizer.h>
#include <metis.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cfloat>
#include <functional>
#include <cstring>
#include <memory>
#include <mutex>

#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/cluster_dag.h"

namespace vgeo::build_detail {

namespace {

uint64_t hash_position(const float* p) {
  uint32_t b[3];
  std::memcpy(b, p, sizeof(b));
  uint64_t h = 0x9E3779B97F4A7C15ull;
  for (uint32_t x : b) {
    h ^= x;
    h *= 0xFF51AFD7ED558CCDull;
    h ^= h >> 29;
  }
  return h;
}

}  // namespace

WeldedMesh weld_positions(const Mesh& mesh) {
  WeldedMesh w;
  w.mesh = &mesh;
  size_t n = mesh.vertex_count();
  w.weld.resize(n);
  // Open addressing, table at least twice the vertex count: expected O(1) probes.
  size_t cap = 16;
  while (cap < 2 * n) cap <<= 1;
  std::vector<uint32_t> table(cap, kNone);
  const float* pos = mesh.positions.data();
  for (size_t v = 0; v < n; ++v) {
    size_t slot = hash_position(pos + 3 * v) & (cap - 1);
    for (;;) {
      uint32_t e = table[slot];
      if (e == kNone) {
        table[slot] = uint32_t(v);
        w.weld[v] = uint32_t(v);
        break;
      }
      if (std::memcmp(pos + 3 * e, pos + 3 * v, 12) == 0) {
        w.weld[v] = e;
        break;
      }
      slot = (slot + 1) & (cap - 1);
    }
  }
  w.copies.assign(n, 0);
  for (size_t v = 0; v < n; ++v) {
    uint8_t& c = w.copies[w.weld[v]];
    if (c < 255) ++c;  // saturates: only "more than kMaxSeamWedges" is asked
  }
  return w;
}

Sphere sphere_of_points(const Mesh& mesh, const uint32_t* vertices, size_t count) {
  Sphere s;
  if (count == 0) return s;
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (size_t i = 0; i < count; ++i) {
    Vec3 p = mesh.position(vertices[i]);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(p[k]));
      hi[k] = std::max(hi[k], double(p[k]));
    }
  }
  s.center = {float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[1] + hi[1])), float(0.5 * (lo[2] + hi[2]))};
  double r = 0;
  for (size_t i = 0; i < count; ++i) r = std::max(r, distance_d(s.center, mesh.position(vertices[i])));
  s.radius = float(r * (1.0 + kSphereRelativeSlack)) + std::numeric_limits<float>::min();
  return s;
}

Sphere enclose_spheres(const Sphere* spheres, size_t count) {
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  bool any = false;
  for (size_t i = 0; i < count; ++i) {
    const Sphere& s = spheres[i];
    if (s.radius < 0) continue;
    any = true;
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(s.center[k]) - s.radius);
      hi[k] = std::max(hi[k], double(s.center[k]) + s.radius);
    }
  }
  Sphere out;
  if (!any) return out;
  out.center = {float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[1] + hi[1])), float(0.5 * (lo[2] + hi[2]))};
  double r = 0;
  for (size_t i = 0; i < count; ++i)
    if (spheres[i].radius >= 0) r = std::max(r, distance_d(out.center, spheres[i].center) + spheres[i].radius);
  out.radius = float(r * (1.0 + kSphereRelativeSlack)) + std::numeric_limits<float>::min();
  // A single sphere (or identical ones) is returned as is: siblings keep bit-identical values.
  bool all_same = true;
  const Sphere* first = nullptr;
  for (size_t i = 0; i < count && all_same; ++i) {
    if (spheres[i].radius < 0) continue;
    if (!first) first = &spheres[i];
    else all_same = std::memcmp(first, &spheres[i], sizeof(Sphere)) == 0;
  }
  if (all_same && first) return *first;
  return out;
}

void count_cluster_edges(const WeldedMesh& welded, const TriangleSet& cluster, uint64_t* open_edges,
                         uint64_t* all_edges, std::vector<uint64_t>* open_keys) {
  // Uses per distinct welded edge in an open addressing table (load ≤ 1/2) instead of a
  // sort of all keys: only the open keys (a minority) are sorted.
  const size_t n = cluster.triangle_count();
  size_t slots = 16;
  int shift = 60;  // hash = top log2(slots) bits of a multiplicative hash
  while (slots < 6 * n) slots <<= 1, --shift;
  constexpr uint64_t kEmpty = ~uint64_t(0);  // no edge key (a < b) equals it
  std::vector<uint64_t> table(slots, kEmpty);
  std::vector<uint32_t> uses(slots, 0);
  uint64_t all = 0;
  for_each_welded_edge(welded, cluster.corners, [&](uint32_t a, uint32_t b) {
    if (a == b) return;
    const uint64_t key = edge_key(a, b);
    size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> shift);
    while (table[h] != kEmpty && table[h] != key) h = (h + 1) & (slots - 1);
    if (table[h] == kEmpty) table[h] = key, ++all;
    ++uses[h];
  });
  uint64_t open = 0;
  const size_t first_open = open_keys ? open_keys->size() : 0;
  for (size_t h = 0; h < slots; ++h)
    if (uses[h] == 1) {
      ++open;
      if (open_keys) open_keys->push_back(table[h]);
    }
  if (open_keys) std::sort(open_keys->begin() + ptrdiff_t(first_open), open_keys->end());
  *open_edges = open;
  *all_edges = all;
}

namespace {

// Compacts the welded ids of `tris` into local ids [0, n) in order of first use.
// Returns the welded ids per local id; `local_corner` gets 3 local ids per triangle.
std::vector<uint32_t> compact_welded(const WeldedMesh& welded, const TriangleSet& tris,
                                     std::vector<uint32_t>& scratch, std::vector<uint32_t>& local_corner) {
  std::vector<uint32_t> welded_of_local;
  local_corner.resize(tris.corners.size());
  for (size_t i = 0; i < tris.corners.size(); ++i) {
    uint32_t w = welded.weld[tris.corners[i]];
    if (scratch[w] == kNone) {
      scratch[w] = uint32_t(welded_of_local.size());
      welded_of_local.push_back(w);
    }
    local_corner[i] = scratch[w];
  }
  for (uint32_t w : welded_of_local) scratch[w] = kNone;
  return welded_of_local;
}

// Appends the clusters holding triangles `ids` (indices into tris), bisecting in order
// until the original-vertex limit holds (attribute seams can push a welded cluster of
// ≤ 255 positions over 255 vertices).
void emit_cluster(const TriangleSet& tris, const uint32_t* ids, size_t count, std::vector<uint32_t>& scratch,
                  std::vector<TriangleSet>& out) {
  uint32_t unique = 0;
  std::vector<uint32_t> touched;
  for (size_t i = 0; i < count; ++i)
    for (int k = 0; k < 3; ++k) {
      uint32_t v = tris.corners[3 * ids[i] + k];
      if (scratch[v] == kNone) {
        scratch[v] = 0;
        touched.push_back(v);
        ++unique;
      }
    }
  for (uint32_t v : touched) scratch[v] = kNone;
  if (count > kMaxClusterTriangles || unique > kMaxClusterVertices) {
    assert(count > 1);
    size_t half = count / 2;
    emit_cluster(tris, ids, half, scratch, out);
    emit_cluster(tris, ids + half, count - half, scratch, out);
    return;
  }
  TriangleSet c;
  c.corners.reserve(3 * count);
  c.materials.reserve(count);
  for (size_t i = 0; i < count; ++i) {
    c.corners.insert(c.corners.end(), &tris.corners[3 * ids[i]], &tris.corners[3 * ids[i]] + 3);
    c.materials.push_back(tris.materials[ids[i]]);
  }
  out.push_back(std::move(c));
}

std::vector<TriangleSet> split_meshopt(const WeldedMesh& welded, const TriangleSet& tris,
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

// ---- the cluster grower (SplitMethod::kGrow, spec/dag.md §2.2) ----
// meshopt_buildMeshlets' greedy rule (0.18, cone weight 0) with data structures that make a
// step O(log frontier) instead of a scan of every cluster vertex's triangles: a cluster grows by
// the adjacent triangle that adds the fewest new vertices (a triangle at a vertex with one
// triangle left counts as adding one, so corners are not left behind), then by distance to
// the cluster's centroid; a full cluster's successor starts next to it where the fewest
// triangles are left; with no adjacent triangle the nearest unclustered one (k-d tree) joins.

// Centroid distances are re-measured from the cluster's current centroid when it reaches
// these sizes (the heap's keys are frozen in between): powers of two up to half a cluster.
constexpr uint32_t kRecentreFirst = 4;
// k-d tree leaves hold up to this many triangles (the nearest search scans a leaf linearly).
constexpr uint32_t kKdLeafSize = 16;
// Up to this many triangles (a group's split) the nearest search is a scan: building the
// tree would cost more than the few searches such a split makes.
constexpr size_t kNearestScanMaxTriangles = 2048;

inline float squared_distance(const float* a, const float* b) {
  return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
}

// Triangle centroids in a k-d tree whose nodes count their unclustered triangles, so the
// nearest search skips clustered regions. Built on first use: connected meshes rarely need it.
struct CentroidTree {
  struct Node {
    uint32_t begin = 0, end = 0;  // range of `order`
    uint32_t left = kNone, right = kNone, parent = kNone;
    uint32_t remaining = 0;
    float lo[3], hi[3];
  };
  std::vector<Node> nodes;
  std::vector<uint32_t> order;  // triangle ids, leaf ranges contiguous
  std::vector<uint32_t> leaf_of;
  const float* centroids = nullptr;

  bool built() const { return centroids != nullptr; }
  void build(const float* c, size_t n, const std::vector<uint8_t>& clustered) {
    centroids = c;
    order.clear();
    for (uint32_t t = 0; t < n; ++t)
      if (!clustered[t]) order.push_back(t);
    leaf_of.assign(n, kNone);
    nodes.clear();
    nodes.reserve(2 * (order.size() / kKdLeafSize + 1));
    if (!order.empty()) split(0, uint32_t(order.size()), kNone);
  }
  uint32_t split(uint32_t begin, uint32_t end, uint32_t parent) {
    const uint32_t id = uint32_t(nodes.size());
    nodes.push_back(Node());
    Node node;
    node.begin = begin, node.end = end, node.parent = parent, node.remaining = end - begin;
    for (int k = 0; k < 3; ++k) node.lo[k] = FLT_MAX, node.hi[k] = -FLT_MAX;
    for (uint32_t i = begin; i < end; ++i)
      for (int k = 0; k < 3; ++k) {
        node.lo[k] = std::min(node.lo[k], centroids[3 * order[i] + k]);
        node.hi[k] = std::max(node.hi[k], centroids[3 * order[i] + k]);
      }
    if (end - begin <= kKdLeafSize) {
      for (uint32_t i = begin; i < end; ++i) leaf_of[order[i]] = id;
      nodes[id] = node;
      return id;
    }
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (node.hi[k] - node.lo[k] > node.hi[axis] - node.lo[axis]) axis = k;
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](uint32_t a, uint32_t b) {
      const float ca = centroids[3 * a + axis], cb = centroids[3 * b + axis];
      return ca < cb || (ca == cb && a < b);
    });
    nodes[id] = node;
    const uint32_t left = split(begin, mid, id);
    const uint32_t right = split(mid, end, id);
    nodes[id].left = left, nodes[id].right = right;
    return id;
  }
  void remove(uint32_t t) {
    if (!built()) return;
    for (uint32_t n = leaf_of[t]; n != kNone; n = nodes[n].parent) --nodes[n].remaining;
  }
  // Nearest unclustered triangle to p (ties: smaller id); kNone when none is left.
  uint32_t nearest(const float* p, const std::vector<uint8_t>& clustered) const {
    uint32_t best = kNone;
    float best_d2 = FLT_MAX;
    if (!nodes.empty()) search(0, p, clustered, best, best_d2);
    return best;
  }
  void search(uint32_t id, const float* p, const std::vector<uint8_t>& clustered, uint32_t& best, float& best_d2) const {
    const Node& node = nodes[id];
    if (node.remaining == 0) return;
    float box_d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const float d = std::max({node.lo[k] - p[k], 0.0f, p[k] - node.hi[k]});
      box_d2 += d * d;
    }
    if (box_d2 > best_d2) return;
    if (node.left == kNone) {
      for (uint32_t i = node.begin; i < node.end; ++i) {
        const uint32_t t = order[i];
        if (clustered[t]) continue;
        const float d2 = squared_distance(&centroids[3 * t], p);
        if (d2 < best_d2 || (d2 == best_d2 && t < best)) best = t, best_d2 = d2;
      }
      return;
    }
    search(node.left, p, clustered, best, best_d2);
    search(node.right, p, clustered, best, best_d2);
  }
};

// Candidate triangle of the growing cluster; smaller is better.
struct GrowCandidate {
  uint32_t priority;  // 0: adds no vertex; else 1 + new vertices (0 if it holds a last-triangle vertex)
  float distance2;    // to the cluster centroid when keyed
  uint32_t triangle;
  bool operator>(const GrowCandidate& o) const {
    if (priority != o.priority) return priority > o.priority;
    if (distance2 != o.distance2) return distance2 > o.distance2;
    return triangle > o.triangle;
  }
};

std::vector<TriangleSet> split_grow(const WeldedMesh& welded, const TriangleSet& tris, std::vector<uint32_t>& scratch) {
  const Mesh& mesh = *welded.mesh;
  const size_t n = tris.triangle_count();
  std::vector<uint32_t> local;
  const std::vector<uint32_t> welded_of_local = compact_welded(welded, tris, scratch, local);
  const size_t vcount = welded_of_local.size();
  std::vector<float> centroid(3 * n);
  for (size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const size_t a = welded_of_local[local[3 * t]], b = welded_of_local[local[3 * t + 1]],
                   c = welded_of_local[local[3 * t + 2]];
      centroid[3 * t + k] = (mesh.positions[3 * a + k] + mesh.positions[3 * b + k] + mesh.positions[3 * c + k]) / 3.0f;
    }
  // Unclustered triangles per vertex (CSR; a triangle leaves its vertices' lists when clustered).
  std::vector<uint32_t> first(vcount + 1, 0), live(vcount, 0), adjacency(3 * n);
  for (uint32_t v : local) ++live[v];
  for (size_t v = 0; v < vcount; ++v) first[v + 1] = first[v] + live[v];
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (size_t i = 0; i < local.size(); ++i) adjacency[fill[local[i]]++] = uint32_t(i / 3);
  }
  CentroidTree tree;
  std::vector<uint8_t> clustered(n, 0);
  std::vector<uint32_t> in_cluster(vcount, kNone);  // stamp: index of the cluster using the vertex
  std::vector<GrowCandidate> heap;
  std::vector<uint32_t> ids;  // the cluster's triangles in order of addition
  std::vector<TriangleSet> out;
  uint32_t stamp = 0, cluster_vertices = 0;
  double sum[3] = {0, 0, 0};
  float centre[3] = {0, 0, 0};

  auto new_vertices = [&](uint32_t t) {
    const uint32_t* c = &local[3 * size_t(t)];
    return uint32_t(in_cluster[c[0]] != stamp) + (in_cluster[c[1]] != stamp) + (in_cluster[c[2]] != stamp);
  };
  auto priority_of = [&](uint32_t t) {
    const uint32_t extra = new_vertices(t);
    if (extra == 0) return 0u;
    const uint32_t* c = &local[3 * size_t(t)];
    const bool dangling = live[c[0]] == 1 || live[c[1]] == 1 || live[c[2]] == 1;
    return 1 + (dangling ? 0 : extra);
  };
  auto distance2 = [&](uint32_t t) { return squared_distance(&centroid[3 * size_t(t)], centre); };
  auto push = [&](uint32_t t) {
    heap.push_back({priority_of(t), distance2(t), t});
    std::push_heap(heap.begin(), heap.end(), std::greater<GrowCandidate>());
  };
  auto recentre = [&] {
    for (int k = 0; k < 3; ++k) centre[k] = float(sum[k] / double(ids.size()));
    size_t kept = 0;
    for (const GrowCandidate& g : heap)
      if (!clustered[g.triangle]) heap[kept++] = {priority_of(g.triangle), distance2(g.triangle), g.triangle};
    heap.resize(kept);
    std::make_heap(heap.begin(), heap.end(), std::greater<GrowCandidate>());
  };
  auto finish_cluster = [&] {
    if (!ids.empty()) emit_cluster(tris, ids.data(), ids.size(), scratch, out);
    ids.clear();
    heap.clear();
    ++stamp;
    cluster_vertices = 0;
    sum[0] = sum[1] = sum[2] = 0;
  };
  auto add = [&](uint32_t t) {
    clustered[t] = 1;
    tree.remove(t);
    ids.push_back(t);
    for (int k = 0; k < 3; ++k) sum[k] += centroid[3 * size_t(t) + k];
    if (ids.size() == 1)
      for (int k = 0; k < 3; ++k) centre[k] = centroid[3 * size_t(t) + k];
    const uint32_t* c = &local[3 * size_t(t)];
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = c[k];
      uint32_t* list = &adjacency[first[v]];
      for (uint32_t i = 0; i < live[v]; ++i)
        if (list[i] == t) {
          list[i] = list[--live[v]];
          break;
        }
    }
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = c[k];
      if (in_cluster[v] != stamp) {
        in_cluster[v] = stamp;
        ++cluster_vertices;
        for (uint32_t i = 0; i < live[v]; ++i) push(adjacency[first[v] + i]);
      } else if (live[v] == 1) {
        push(adjacency[first[v]]);  // now the last triangle at v: a better candidate
      }
    }
    if (ids.size() >= kRecentreFirst && (ids.size() & (ids.size() - 1)) == 0 && ids.size() < kMaxClusterTriangles)
      recentre();
  };
  auto best_candidate = [&] {
    while (!heap.empty() && clustered[heap.front().triangle]) {
      std::pop_heap(heap.begin(), heap.end(), std::greater<GrowCandidate>());
      heap.pop_back();
    }
    return heap.empty() ? kNone : heap.front().triangle;
  };
  // The next cluster's first triangle, next to the full one: fewest new vertices, then the
  // fewest triangles left at its corners (so the sweep hugs the clustered region).
  auto successor_seed = [&] {
    uint32_t best = kNone, best_priority = UINT32_MAX, best_live = UINT32_MAX;
    for (const GrowCandidate& g : heap) {
      const uint32_t t = g.triangle;
      if (clustered[t]) continue;
      const uint32_t* c = &local[3 * size_t(t)];
      const uint32_t p = priority_of(t), l = live[c[0]] + live[c[1]] + live[c[2]];
      if (p < best_priority || (p == best_priority && (l < best_live || (l == best_live && t < best))))
        best = t, best_priority = p, best_live = l;
    }
    return best;
  };

  auto nearest_to_cluster = [&] {
    float c[3];
    for (int k = 0; k < 3; ++k) c[k] = float(sum[k] / double(ids.size()));
    if (n > kNearestScanMaxTriangles) {
      if (!tree.built()) tree.build(centroid.data(), n, clustered);
      return tree.nearest(c, clustered);
    }
    uint32_t best = kNone;
    float best_d2 = FLT_MAX;
    for (uint32_t t = 0; t < n; ++t) {
      if (clustered[t]) continue;
      const float d2 = squared_distance(&centroid[3 * size_t(t)], c);
      if (d2 < best_d2) best = t, best_d2 = d2;
    }
    return best;
  };

  // Start at the triangle with the lowest centroid along x, then y, z (then id): sweeping from
  // an extreme leaves fewer enclosed remainders than starting inside.
  uint32_t next = 0;
  for (uint32_t t = 1; t < n; ++t)
    if (std::lexicographical_compare(&centroid[3 * size_t(t)], &centroid[3 * size_t(t)] + 3, &centroid[3 * size_t(next)],
                                     &centroid[3 * size_t(next)] + 3))
      next = t;
  for (size_t done = 0; next != kNone;) {
    add(next);
    if (++done == n) break;
    next = best_candidate();
    const bool full = ids.size() >= kMaxClusterTriangles ||
                      (next != kNone && cluster_vertices + new_vertices(next) > kMaxClusterVertices);
    if (full) {
      next = successor_seed();
      const uint32_t nearest = next == kNone ? nearest_to_cluster() : kNone;
      finish_cluster();
      if (next == kNone) next = nearest;
    } else if (next == kNone) {
      next = nearest_to_cluster();
    }
  }
  finish_cluster();
  return out;
}

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
    rc = METIS_PartGraphRecursive(&nvtxs, &ncon, xadj.data(), adjncy.data(), nullptr, nullptr, nullptr, &nparts,
                                  tpwgts, nullptr, options, &objval, part.data());
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

std::vector<TriangleSet> split_proper(const WeldedMesh& welded, const TriangleSet& tris, std::vector<uint32_t>& scratch,
                                      SplitMethod method) {
  switch (method) {
    case SplitMethod::kMetis: return split_metis(welded, tris, scratch);
    case SplitMethod::kGrow: return split_grow(welded, tris, scratch);
    default: return split_meshopt(welded, tris, scratch);
  }
}

// Emits triangles [begin, end) of `tris` (`ids` = identity order) as emit_cluster does, but
// bisects at the unit start (`units`, ascending: a proper triangle followed by the degenerate
// ones placed with it) nearest the middle, so a unit stays in one piece.
void emit_units(const TriangleSet& tris, const uint32_t* ids, size_t begin, size_t end,
                const std::vector<uint32_t>& units, std::vector<uint32_t>& scratch, std::vector<TriangleSet>& out) {
  uint32_t unique = 0;
  for (size_t i = begin; i < end; ++i)
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = tris.corners[3 * ids[i] + k];
      if (scratch[v] == kNone) scratch[v] = 0, ++unique;
    }
  for (size_t i = begin; i < end; ++i)
    for (int k = 0; k < 3; ++k) scratch[tris.corners[3 * ids[i] + k]] = kNone;
  const auto lo = std::upper_bound(units.begin(), units.end(), uint32_t(begin));
  const auto hi = std::lower_bound(lo, units.end(), uint32_t(end));
  if ((end - begin <= kMaxClusterTriangles && unique <= kMaxClusterVertices) || lo == hi) {
    emit_cluster(tris, ids + begin, end - begin, scratch, out);
    return;
  }
  const uint32_t middle = uint32_t(begin + (end - begin) / 2);
  auto cut = std::lower_bound(lo, hi, middle);
  if (cut == hi || (cut != lo && middle - *(cut - 1) < *cut - middle)) --cut;
  emit_units(tris, ids, begin, *cut, units, scratch, out);
  emit_units(tris, ids, *cut, end, units, scratch, out);
}

// Adds each degenerate triangle (`ids` into `tris`, ascending) to the first cluster (in
// cluster order) that uses every one of its welded positions that proper triangles use, right
// after that cluster's first triangle at one of them; a cluster that grows past the limits is
// bisected in that order (emit_cluster), so the pieces stay local. A degenerate triangle
// placed elsewhere would bring a position into a group that does not otherwise use it: locked
// there, and lost when the simplifier drops the degenerate triangle (a stuck group). Those
// no cluster holds entirely are clustered among themselves. Output: `clusters` in order
// (grown ones replaced by their pieces), then the clusters of those left over.
std::vector<TriangleSet> attach_degenerate(const WeldedMesh& welded, const TriangleSet& tris,
                                           const std::vector<uint32_t>& ids, std::vector<TriangleSet> clusters,
                                           std::vector<uint32_t>& scratch, SplitMethod method) {
  constexpr uint32_t kWanted = 0, kSeen = 1;  // scratch marks: a degenerate's position (seen in this cluster)
  std::vector<uint32_t> wanted;
  for (uint32_t id : ids)
    for (int k = 0; k < 3; ++k) {
      const uint32_t w = welded.weld[tris.corners[3 * size_t(id) + k]];
      if (scratch[w] == kNone) scratch[w] = kWanted, wanted.push_back(w);
    }
  // (position, cluster, first triangle of the cluster at that position), sorted.
  std::vector<std::array<uint32_t, 3>> uses;
  for (size_t c = 0; c < clusters.size(); ++c) {
    const size_t first_use = uses.size();
    for (size_t i = 0; i < clusters[c].corners.size(); ++i) {
      const uint32_t w = welded.weld[clusters[c].corners[i]];
      if (scratch[w] != kWanted) continue;
      scratch[w] = kSeen;
      uses.push_back({w, uint32_t(c), uint32_t(i / 3)});
    }
    for (size_t u = first_use; u < uses.size(); ++u) scratch[uses[u][0]] = kWanted;
  }
  for (uint32_t w : wanted) scratch[w] = kNone;
  std::sort(uses.begin(), uses.end());
  auto uses_of = [&](uint32_t w) {
    auto lo = std::lower_bound(uses.begin(), uses.end(), std::array<uint32_t, 3>{w, 0, 0});
    auto hi = std::lower_bound(lo, uses.end(), std::array<uint32_t, 3>{w + 1, 0, 0});
    return std::make_pair(lo, hi);
  };
  // Per cluster, the degenerates placed in it: (anchor triangle, index into ids). A position
  // that only degenerate triangles use ties them to one place: the first one's (scratch[w] =
  // index into `placements`), or the leftovers.
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> attached(clusters.size());
  std::vector<std::pair<uint32_t, uint32_t>> placements;  // (cluster or kNone = leftover, anchor)
  std::vector<uint32_t> tied;
  TriangleSet leftover;
  for (size_t d = 0; d < ids.size(); ++d) {
    const uint32_t* corners = &tris.corners[3 * size_t(ids[d])];
    uint32_t w[3];
    bool used[3];
    for (int k = 0; k < 3; ++k) {
      w[k] = welded.weld[corners[k]];
      used[k] = uses_of(w[k]).first != uses_of(w[k]).second;
    }
    // Where the tied positions already point (kNone: free).
    uint32_t tie = kNone;
    bool conflict = false;
    for (int k = 0; k < 3; ++k)
      if (!used[k] && scratch[w[k]] != kNone) {
        if (tie != kNone && placements[tie] != placements[scratch[w[k]]]) conflict = true;
        tie = scratch[w[k]];
      }
    const uint32_t tie_cluster = tie == kNone ? kNone : placements[tie].first;
    uint32_t best_cluster = kNone, best_triangle = kNone;
    int first = -1;
    for (int k = 0; k < 3 && first < 0; ++k)
      if (used[k]) first = k;
    if (conflict || (tie != kNone && tie_cluster == kNone)) {
      // tied to the leftovers
    } else if (first < 0) {
      if (tie != kNone) best_cluster = tie_cluster, best_triangle = placements[tie].second;
    } else {
      // Candidates: the clusters of a used position; each must hold the other used positions.
      for (auto [it, end] = uses_of(w[first]); it != end && best_cluster == kNone; ++it) {
        const uint32_t c = (*it)[1];
        if (tie_cluster != kNone && c != tie_cluster) continue;
        uint32_t anchor = (*it)[2];
        bool holds_all = true;
        for (int k = 0; k < 3 && holds_all; ++k) {
          if (!used[k]) continue;
          auto [lo, hi] = uses_of(w[k]);
          auto at = std::lower_bound(lo, hi, std::array<uint32_t, 3>{w[k], c, 0});
          holds_all = at != hi && (*at)[1] == c;
          if (holds_all) anchor = std::min(anchor, (*at)[2]);
        }
        if (!holds_all) continue;
        // Better: a triangle holding all of them (the proper side of a degenerate one's edge),
        // so a bisection that keeps the two together keeps the positions in one piece.
        const TriangleSet& cl = clusters[c];
        for (size_t t = 0; t < cl.triangle_count(); ++t) {
          bool all = true;
          for (int k = 0; k < 3 && all; ++k) {
            if (!used[k]) continue;
            const uint32_t* tc = &cl.corners[3 * t];
            all = welded.weld[tc[0]] == w[k] || welded.weld[tc[1]] == w[k] || welded.weld[tc[2]] == w[k];
          }
          if (all) {
            anchor = uint32_t(t);
            break;
          }
        }
        best_cluster = c, best_triangle = anchor;
      }
    }
    for (int k = 0; k < 3; ++k)
      if (!used[k] && scratch[w[k]] == kNone) {
        scratch[w[k]] = uint32_t(placements.size());
        tied.push_back(w[k]);
      }
    placements.push_back({best_cluster, best_triangle});
    if (best_cluster != kNone) {
      attached[best_cluster].push_back({best_triangle, uint32_t(d)});
    } else {
      leftover.corners.insert(leftover.corners.end(), corners, corners + 3);
      leftover.materials.push_back(tris.materials[ids[d]]);
    }
  }
  for (uint32_t x : tied) scratch[x] = kNone;
  std::vector<TriangleSet> out;
  out.reserve(clusters.size() + 1);
  std::vector<uint32_t> order, units;
  for (size_t c = 0; c < clusters.size(); ++c) {
    if (attached[c].empty()) {
      out.push_back(std::move(clusters[c]));
      continue;
    }
    std::stable_sort(attached[c].begin(), attached[c].end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });
    // The grown cluster as one triangle list (its triangles, each followed by its degenerates).
    TriangleSet grown;
    const TriangleSet& cl = clusters[c];
    size_t next = 0;
    auto append = [&](const uint32_t* corners, uint32_t material) {
      grown.corners.insert(grown.corners.end(), corners, corners + 3);
      grown.materials.push_back(material);
    };
    units.clear();
    for (size_t t = 0; t < cl.triangle_count(); ++t) {
      units.push_back(uint32_t(grown.triangle_count()));
      append(&cl.corners[3 * t], cl.materials[t]);
      for (; next < attached[c].size() && attached[c][next].first == t; ++next) {
        const uint32_t id = ids[attached[c][next].second];
        append(&tris.corners[3 * size_t(id)], tris.materials[id]);
      }
    }
    order.resize(grown.triangle_count());
    for (size_t i = 0; i < order.size(); ++i) order[i] = uint32_t(i);
    emit_units(grown, order.data(), 0, order.size(), units, scratch, out);
  }
  if (leftover.triangle_count() > 0)
    for (TriangleSet& t : split_proper(welded, leftover, scratch, method)) out.push_back(std::move(t));
  return out;
}

}  // namespace

bool is_degenerate(const WeldedMesh& welded, const uint32_t* corners) {
  const uint32_t a = welded.weld[corners[0]], b = welded.weld[corners[1]], c = welded.weld[corners[2]];
  if (a == b || b == c || c == a) return true;
  const Mesh& mesh = *welded.mesh;
  double p[3][3];
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j) p[k][j] = mesh.positions[3 * size_t(corners[k]) + size_t(j)];
  double e[3][3], longest2 = 0;
  for (int k = 0; k < 3; ++k) {
    double l2 = 0;
    for (int j = 0; j < 3; ++j) {
      e[k][j] = p[(k + 1) % 3][j] - p[k][j];
      l2 += e[k][j] * e[k][j];
    }
    longest2 = std::max(longest2, l2);
  }
  const double n[3] = {e[0][1] * e[2][2] - e[0][2] * e[2][1], e[0][2] * e[2][0] - e[0][0] * e[2][2],
                       e[0][0] * e[2][1] - e[0][1] * e[2][0]};
  // |n| = longest edge × height: height < h·longest  <=>  |n|^2 < h^2·longest^4.
  const double n2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
  return n2 < kDegenerateRelativeHeight * kDegenerateRelativeHeight * longest2 * longest2;
}

FinSet find_fins(const WeldedMesh& welded, ThreadPool& pool) {
  const Mesh& mesh = *welded.mesh;
  const size_t n = mesh.triangle_count();
  // Collinear slivers on three distinct positions, per task in triangle order (deterministic).
  const size_t tasks = (n + kFinScanTriangles - 1) / kFinScanTriangles;
  std::vector<std::vector<uint32_t>> found(tasks);
  pool.parallel_for(tasks, [&](size_t k) {
    for (size_t t = k * kFinScanTriangles; t < std::min(n, (k + 1) * kFinScanTriangles); ++t) {
      const uint32_t* c = &mesh.indices[3 * t];
      const uint32_t a = welded.weld[c[0]], b = welded.weld[c[1]], d = welded.weld[c[2]];
      if (a != b && b != d && d != a && is_degenerate(welded, c)) found[k].push_back(uint32_t(t));
    }
  });
  std::vector<uint32_t> slivers;
  for (const auto& f : found) slivers.insert(slivers.end(), f.begin(), f.end());
  if (slivers.empty()) return {};
  // Parity of every welded edge at a sliver's positions, over the whole mesh.
  std::vector<uint8_t> at_sliver(mesh.vertex_count(), 0), odd_end(mesh.vertex_count(), 0);
  for (uint32_t t : slivers)
    for (int k = 0; k < 3; ++k) at_sliver[welded.weld[mesh.indices[3 * size_t(t) + k]]] = 1;
  std::vector<uint64_t> edges;
  for_each_welded_edge(welded, mesh.indices, [&](uint32_t a, uint32_t b) {
    if (a != b && (at_sliver[a] || at_sliver[b])) edges.push_back(edge_key(a, b));
  });
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if ((j - i) % 2 == 1) odd_end[uint32_t(edges[i] >> 32)] = odd_end[uint32_t(edges[i])] = 1;
    i = j;
  }
  FinSet fins;
  for (uint32_t t : slivers) {
    const uint32_t* c = &mesh.indices[3 * size_t(t)];
    if (!odd_end[welded.weld[c[0]]] || !odd_end[welded.weld[c[1]]] || !odd_end[welded.weld[c[2]]]) continue;
    std::array<uint32_t, 3> key{c[0], c[1], c[2]};
    std::sort(key.begin(), key.end());
    fins.push_back(key);
  }
  std::sort(fins.begin(), fins.end());
  return fins;
}

std::mutex& metis_mutex() {
  static std::mutex m;
  return m;
}

std::vector<TriangleSet> split_into_clusters(const WeldedMesh& welded, const TriangleSet& tris,
                                             std::vector<uint32_t>& scratch, SplitMethod method) {
  const size_t n = tris.triangle_count();
  if (n == 0) return {};
  // Degenerate triangles are left out of the clusterizer and attached afterwards: meshopt
  // gathers them into clusters that span the mesh, whose positions then lock every group
  // border (issue 15; spec/dag.md §2.2).
  std::vector<uint32_t> degenerate;
  for (size_t t = 0; t < n; ++t)
    if (is_degenerate(welded, &tris.corners[3 * t])) degenerate.push_back(uint32_t(t));
  if (degenerate.empty() || degenerate.size() == n) return split_proper(welded, tris, scratch, method);
  TriangleSet proper;
  proper.corners.reserve(3 * (n - degenerate.size()));
  proper.materials.reserve(n - degenerate.size());
  for (size_t t = 0, d = 0; t < n; ++t) {
    if (d < degenerate.size() && degenerate[d] == t) {
      ++d;
      continue;
    }
    proper.corners.insert(proper.corners.end(), &tris.corners[3 * t], &tris.corners[3 * t] + 3);
    proper.materials.push_back(tris.materials[t]);
  }
  std::vector<TriangleSet> clusters = split_proper(welded, proper, scratch, method);
  return attach_degenerate(welded, tris, degenerate, std::move(clusters), scratch, method);
}

}  // namespace vgeo::build_detail
