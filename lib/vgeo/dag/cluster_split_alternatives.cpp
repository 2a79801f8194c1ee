// The splitters kept for measurement (SplitMethod::kGrow, SplitMethod::kMetis): used by tests,
// `vgeo bench dagquality` and the cluster split benchmark, never by a default build (spec/dag.md
// §2.2, measured in §5).
// Based on: Kapoulkine, meshoptimizer 0.18, meshopt_buildMeshlets (the grower's greedy rule);
// Karypis, Kumar, "A Fast and High Quality Multilevel Scheme for Partitioning Irregular
// Graphs", SIAM J. Sci. Comput. 20(1), 1998 (METIS, the recursive bisection).
#include <metis.h>

#include <algorithm>
#include <cfloat>
#include <functional>
#include <mutex>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

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

// The grower's state over one split: the triangles in local (compacted welded) ids, their
// centroids, each vertex's unclustered triangles, and the cluster being grown.
struct Grower {
  Grower(const TriangleSet& t, std::vector<uint32_t>& s) : tris(t), scratch(s), n(t.triangle_count()) {}
  const TriangleSet& tris;
  std::vector<uint32_t>& scratch;
  size_t n;                      // triangles
  std::vector<uint32_t> local;   // 3 local vertex ids per triangle
  std::vector<float> centroid;   // 3 per triangle
  // Unclustered triangles per vertex (CSR; a triangle leaves its vertices' lists when clustered).
  std::vector<uint32_t> first, live, adjacency;
  CentroidTree tree;
  std::vector<uint8_t> clustered;
  std::vector<uint32_t> in_cluster;  // stamp: index of the cluster using the vertex
  std::vector<GrowCandidate> heap;
  std::vector<uint32_t> ids;  // the cluster's triangles in order of addition
  std::vector<TriangleSet> out;
  uint32_t stamp = 0, cluster_vertices = 0;
  double sum[3] = {0, 0, 0};
  float centre[3] = {0, 0, 0};
};

// Local ids, centroids and the vertex → triangle lists of `g.tris`.
void index_triangles(Grower& g, const WeldedMesh& welded) {
  const Mesh& mesh = *welded.mesh;
  const size_t n = g.n;
  const std::vector<uint32_t> welded_of_local = compact_welded(welded, g.tris, g.scratch, g.local);
  const size_t vcount = welded_of_local.size();
  g.centroid.resize(3 * n);
  for (size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const size_t a = welded_of_local[g.local[3 * t]], b = welded_of_local[g.local[3 * t + 1]],
                   c = welded_of_local[g.local[3 * t + 2]];
      g.centroid[3 * t + k] = (mesh.positions[3 * a + k] + mesh.positions[3 * b + k] + mesh.positions[3 * c + k]) / 3.0f;
    }
  g.first.assign(vcount + 1, 0);
  g.live.assign(vcount, 0);
  g.adjacency.resize(3 * n);
  for (uint32_t v : g.local) ++g.live[v];
  for (size_t v = 0; v < vcount; ++v) g.first[v + 1] = g.first[v] + g.live[v];
  {
    std::vector<uint32_t> fill(g.first.begin(), g.first.end() - 1);
    for (size_t i = 0; i < g.local.size(); ++i) g.adjacency[fill[g.local[i]]++] = uint32_t(i / 3);
  }
  g.clustered.assign(n, 0);
  g.in_cluster.assign(vcount, kNone);
}

uint32_t new_vertices(const Grower& g, uint32_t t) {
  const uint32_t* c = &g.local[3 * size_t(t)];
  return uint32_t(g.in_cluster[c[0]] != g.stamp) + (g.in_cluster[c[1]] != g.stamp) + (g.in_cluster[c[2]] != g.stamp);
}

uint32_t priority_of(const Grower& g, uint32_t t) {
  const uint32_t extra = new_vertices(g, t);
  if (extra == 0) return 0u;
  const uint32_t* c = &g.local[3 * size_t(t)];
  const bool dangling = g.live[c[0]] == 1 || g.live[c[1]] == 1 || g.live[c[2]] == 1;
  return 1 + (dangling ? 0 : extra);
}

float distance2(const Grower& g, uint32_t t) { return squared_distance(&g.centroid[3 * size_t(t)], g.centre); }

void push_candidate(Grower& g, uint32_t t) {
  g.heap.push_back({priority_of(g, t), distance2(g, t), t});
  std::push_heap(g.heap.begin(), g.heap.end(), std::greater<GrowCandidate>());
}

// The cluster's centroid re-measured and every candidate re-keyed from it.
void recentre(Grower& g) {
  for (int k = 0; k < 3; ++k) g.centre[k] = float(g.sum[k] / double(g.ids.size()));
  size_t kept = 0;
  for (const GrowCandidate& c : g.heap)
    if (!g.clustered[c.triangle]) g.heap[kept++] = {priority_of(g, c.triangle), distance2(g, c.triangle), c.triangle};
  g.heap.resize(kept);
  std::make_heap(g.heap.begin(), g.heap.end(), std::greater<GrowCandidate>());
}

// The grown cluster emitted; the next one starts empty.
void finish_cluster(Grower& g) {
  if (!g.ids.empty()) emit_cluster(g.tris, g.ids.data(), g.ids.size(), g.scratch, g.out);
  g.ids.clear();
  g.heap.clear();
  ++g.stamp;
  g.cluster_vertices = 0;
  g.sum[0] = g.sum[1] = g.sum[2] = 0;
}

// Triangle t joins the cluster: it leaves its vertices' lists, and the triangles at its new
// vertices (or at a vertex where it is now the last one) become candidates.
void add_triangle(Grower& g, uint32_t t) {
  g.clustered[t] = 1;
  g.tree.remove(t);
  g.ids.push_back(t);
  for (int k = 0; k < 3; ++k) g.sum[k] += g.centroid[3 * size_t(t) + k];
  if (g.ids.size() == 1)
    for (int k = 0; k < 3; ++k) g.centre[k] = g.centroid[3 * size_t(t) + k];
  const uint32_t* c = &g.local[3 * size_t(t)];
  for (int k = 0; k < 3; ++k) {
    const uint32_t v = c[k];
    uint32_t* list = &g.adjacency[g.first[v]];
    for (uint32_t i = 0; i < g.live[v]; ++i)
      if (list[i] == t) {
        list[i] = list[--g.live[v]];
        break;
      }
  }
  for (int k = 0; k < 3; ++k) {
    const uint32_t v = c[k];
    if (g.in_cluster[v] != g.stamp) {
      g.in_cluster[v] = g.stamp;
      ++g.cluster_vertices;
      for (uint32_t i = 0; i < g.live[v]; ++i) push_candidate(g, g.adjacency[g.first[v] + i]);
    } else if (g.live[v] == 1) {
      push_candidate(g, g.adjacency[g.first[v]]);  // now the last triangle at v: a better candidate
    }
  }
  const size_t size = g.ids.size();
  if (size >= kRecentreFirst && (size & (size - 1)) == 0 && size < kMaxClusterTriangles) recentre(g);
}

// The best unclustered candidate (clustered ones are dropped from the heap); kNone if none.
uint32_t best_candidate(Grower& g) {
  while (!g.heap.empty() && g.clustered[g.heap.front().triangle]) {
    std::pop_heap(g.heap.begin(), g.heap.end(), std::greater<GrowCandidate>());
    g.heap.pop_back();
  }
  return g.heap.empty() ? kNone : g.heap.front().triangle;
}

// The next cluster's first triangle, next to the full one: fewest new vertices, then the
// fewest triangles left at its corners (so the sweep hugs the clustered region).
uint32_t successor_seed(const Grower& g) {
  uint32_t best = kNone, best_priority = UINT32_MAX, best_live = UINT32_MAX;
  for (const GrowCandidate& cand : g.heap) {
    const uint32_t t = cand.triangle;
    if (g.clustered[t]) continue;
    const uint32_t* c = &g.local[3 * size_t(t)];
    const uint32_t p = priority_of(g, t), l = g.live[c[0]] + g.live[c[1]] + g.live[c[2]];
    if (p < best_priority || (p == best_priority && (l < best_live || (l == best_live && t < best))))
      best = t, best_priority = p, best_live = l;
  }
  return best;
}

// The unclustered triangle nearest the cluster's centroid (a scan, or the k-d tree built on
// first use for large splits); kNone when none is left.
uint32_t nearest_to_cluster(Grower& g) {
  float c[3];
  for (int k = 0; k < 3; ++k) c[k] = float(g.sum[k] / double(g.ids.size()));
  if (g.n > kNearestScanMaxTriangles) {
    if (!g.tree.built()) g.tree.build(g.centroid.data(), g.n, g.clustered);
    return g.tree.nearest(c, g.clustered);
  }
  uint32_t best = kNone;
  float best_d2 = FLT_MAX;
  for (uint32_t t = 0; t < g.n; ++t) {
    if (g.clustered[t]) continue;
    const float d2 = squared_distance(&g.centroid[3 * size_t(t)], c);
    if (d2 < best_d2) best = t, best_d2 = d2;
  }
  return best;
}

// The triangle with the lowest centroid along x, then y, z (then id): sweeping from an
// extreme leaves fewer enclosed remainders than starting inside.
uint32_t first_seed(const Grower& g) {
  uint32_t next = 0;
  for (uint32_t t = 1; t < g.n; ++t)
    if (std::lexicographical_compare(&g.centroid[3 * size_t(t)], &g.centroid[3 * size_t(t)] + 3,
                                     &g.centroid[3 * size_t(next)], &g.centroid[3 * size_t(next)] + 3))
      next = t;
  return next;
}

}  // namespace

std::vector<TriangleSet> split_grow(const WeldedMesh& welded, const TriangleSet& tris, std::vector<uint32_t>& scratch) {
  Grower g(tris, scratch);
  index_triangles(g, welded);
  uint32_t next = first_seed(g);
  for (size_t done = 0; next != kNone;) {
    add_triangle(g, next);
    if (++done == g.n) break;
    next = best_candidate(g);
    const bool full = g.ids.size() >= kMaxClusterTriangles ||
                      (next != kNone && g.cluster_vertices + new_vertices(g, next) > kMaxClusterVertices);
    if (full) {
      next = successor_seed(g);
      const uint32_t nearest = next == kNone ? nearest_to_cluster(g) : kNone;
      finish_cluster(g);
      if (next == kNone) next = nearest;
    } else if (next == kNone) {
      next = nearest_to_cluster(g);
    }
  }
  finish_cluster(g);
  return std::move(g.out);
}

namespace {

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

}  // namespace vgeo::build_detail
