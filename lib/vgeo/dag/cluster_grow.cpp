// The default cluster splitter (spec/dag.md §2.2): a greedy grower. A cluster (welded ids,
// ≤ kMaxClusterVertices positions, ≤ kMaxClusterTriangles triangles) grows by the adjacent
// triangle that adds the fewest new positions (a triangle at a position with no other
// unclustered triangle counts as adding one, so corners are not left behind), then by the
// distance of its centroid to the cluster's current centroid; a full cluster's best candidate
// starts the next cluster; with no adjacent triangle the nearest unclustered one joins.
// Based on: Kapoulkine, meshoptimizer 0.18, meshopt_buildMeshlets with cone weight 0 (the
// rule, reimplemented from its description; no code taken): the candidates live in priority
// buckets with their centroids, so a step scans the cluster's frontier instead of every
// cluster vertex's triangle list. Same clusters as meshopt 0.18 up to distance ties. A large
// split's triangles are numbered along a Morton curve first (cache locality; the ties are
// broken by input index, so the clusters are those of the input order).
#include <algorithm>
#include <cfloat>
#include <memory>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

// Tree leaves hold up to this many triangles (the nearest search scans a leaf linearly).
constexpr uint32_t kKdLeafSize = 16;
// Up to this many triangles (a group's split) the nearest search is a scan: building the
// tree would cost more than the few searches such a split makes. Larger splits (the leaf
// chunks) are also the ones the grower reorders along the curve: a group's arrays fit in the
// cache anyway.
constexpr size_t kNearestScanMaxTriangles = 2048;

inline float squared_distance(const float* a, const float* b) {
  return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
}

// Bits per axis of the Morton code that orders the centroids: 1024 cells per axis, finer than
// the leaves on any mesh split here (a 2^17-triangle chunk has 8,192 leaves of 16).
constexpr uint32_t kMortonBitsPerAxis = 10;
// The Morton codes are sorted in passes of this many bits (one counting sort per axis' bits).
constexpr uint32_t kRadixBits = kMortonBitsPerAxis;

// Spreads the low 10 bits of x to every third bit (bit i to bit 3i).
inline uint32_t spread_bits(uint32_t x) {
  x &= 0x3FF;
  x = (x | (x << 16)) & 0x030000FF;
  x = (x | (x << 8)) & 0x0300F00F;
  x = (x | (x << 4)) & 0x030C30C3;
  x = (x | (x << 2)) & 0x09249249;
  return x;
}

// The order of a large split's triangles along a Morton curve (radix sort of the codes of their
// centroids in the centroids' bounding box; ties by input index: the passes are stable and
// start in input order). The grower works on its triangles in this order, so the
// triangles at a vertex, a cluster's candidates and their vertices lie near each other in
// its arrays (in bunny00's input order a triangle's neighbours lie thousands of indices away:
// most of the grower's time was cache misses), and the centroid tree's leaves are runs of it.
// `lo` and `hi`: the centroids' bounding box.
std::vector<uint32_t> curve_order(const float* centroids, size_t n, const float lo[3], const float hi[3]) {
  // In double: a float scale over a denormal extent would overflow (0 · inf = NaN).
  constexpr double kCells = double(1u << kMortonBitsPerAxis);
  double scale[3];
  for (int k = 0; k < 3; ++k) scale[k] = hi[k] > lo[k] ? kCells / (double(hi[k]) - double(lo[k])) : 0.0;
  std::vector<uint64_t> keys(n), sorted(n);  // code << 32 | index
  for (size_t t = 0; t < n; ++t) {
    uint32_t code = 0;
    for (int k = 0; k < 3; ++k) {
      const double q = (double(centroids[3 * t + k]) - double(lo[k])) * scale[k];
      code |= spread_bits(uint32_t(std::clamp(q, 0.0, kCells - 1))) << k;
    }
    keys[t] = (uint64_t(code) << 32) | t;
  }
  constexpr uint32_t kBuckets = 1u << kRadixBits;
  for (uint32_t shift = 32; shift < 32 + 3 * kMortonBitsPerAxis; shift += kRadixBits) {
    uint32_t start[kBuckets + 1] = {};
    for (uint64_t key : keys) ++start[((key >> shift) & (kBuckets - 1)) + 1];
    for (uint32_t b = 0; b < kBuckets; ++b) start[b + 1] += start[b];
    for (uint64_t key : keys) sorted[start[(key >> shift) & (kBuckets - 1)]++] = key;
    keys.swap(sorted);
  }
  std::vector<uint32_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = uint32_t(keys[i]);
  return order;
}

// The grower's triangles (its own order: positions 0..n-1, `id` = their input indices, null
// for the input order) in a bounding-box tree whose nodes keep their smallest unclustered
// input index (none: the region is clustered, and the nearest search skips it). Built on
// first use (connected meshes rarely need it) in linear time: leaves of kKdLeafSize
// consecutive positions (runs of the curve order) under a complete binary tree (node i has
// children 2i+1 and 2i+2) whose boxes are merged bottom-up. The search is exact (nearest,
// ties by smaller input index) whatever the tree's shape; the shape only decides how much it
// prunes.
// Based on: Lauterbach et al., "Fast BVH Construction on GPUs", Eurographics 2009 (LBVH:
// primitives sorted by Morton code, a hierarchy over the sorted order).
struct CentroidTree {
  struct Node {
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    // Smallest unclustered input index below (the tie order); kNone when none is left below.
    uint32_t min_id = kNone;
  };
  std::vector<Node> nodes;
  uint32_t leaf_base = 0;  // node index of leaf 0
  size_t n = 0;
  const float* centroids = nullptr;  // 3 per position
  const uint8_t* clustered = nullptr;
  const uint32_t* id = nullptr;

  bool built() const { return centroids != nullptr; }
  uint32_t id_of(uint32_t i) const { return id ? id[i] : i; }
  void build(const float* c, size_t count, const uint8_t* done, const uint32_t* ids) {
    centroids = c, n = count, clustered = done, id = ids;
    const uint32_t leaves = uint32_t((n + kKdLeafSize - 1) / kKdLeafSize);
    uint32_t padded = 1;
    while (padded < leaves) padded <<= 1;
    leaf_base = padded - 1;
    nodes.assign(2 * size_t(padded) - 1, Node());
    for (uint32_t j = 0; j < leaves; ++j) {
      Node& leaf = nodes[leaf_base + j];
      const uint32_t end = uint32_t(std::min<size_t>(n, size_t(j + 1) * kKdLeafSize));
      for (uint32_t i = j * kKdLeafSize; i < end; ++i) {
        const float* p = &centroids[3 * size_t(i)];
        for (int k = 0; k < 3; ++k) leaf.lo[k] = std::min(leaf.lo[k], p[k]), leaf.hi[k] = std::max(leaf.hi[k], p[k]);
        if (!clustered[i]) leaf.min_id = std::min(leaf.min_id, id_of(i));
      }
    }
    for (uint32_t i = leaf_base; i-- > 0;) {
      const Node &l = nodes[2 * i + 1], &r = nodes[2 * i + 2];
      Node& node = nodes[i];
      for (int k = 0; k < 3; ++k) node.lo[k] = std::min(l.lo[k], r.lo[k]), node.hi[k] = std::max(l.hi[k], r.hi[k]);
      node.min_id = std::min(l.min_id, r.min_id);
    }
  }
  // Position i (now clustered) leaves the smallest ids on its path. Only when i was its
  // leaf's smallest does anything change, and only up to the first ancestor whose smallest id
  // stays (its ancestors' stay too): most removals touch one node, not the path to the root.
  void remove(uint32_t i) {
    if (!built()) return;
    const uint32_t leaf = leaf_base + i / kKdLeafSize;
    Node& l = nodes[leaf];
    if (l.min_id != id_of(i)) return;
    l.min_id = kNone;
    const uint32_t begin = (leaf - leaf_base) * kKdLeafSize;
    const uint32_t end = uint32_t(std::min<size_t>(n, begin + kKdLeafSize));
    for (uint32_t j = begin; j < end; ++j)
      if (!clustered[j]) l.min_id = std::min(l.min_id, id_of(j));
    for (uint32_t k = leaf; k != 0;) {
      k = (k - 1) / 2;
      const uint32_t min_id = std::min(nodes[2 * k + 1].min_id, nodes[2 * k + 2].min_id);
      if (nodes[k].min_id == min_id) break;
      nodes[k].min_id = min_id;
    }
  }
  float box_d2(uint32_t node_index, const float* p) const {
    const Node& node = nodes[node_index];
    float d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const float d = std::max({node.lo[k] - p[k], 0.0f, p[k] - node.hi[k]});
      d2 += d * d;
    }
    return d2;
  }
  // The position of the unclustered triangle nearest to p (ties: smaller input index); kNone
  // when none is left.
  uint32_t nearest(const float* p) const {
    uint32_t best = kNone, best_id = kNone;
    float best_d2 = FLT_MAX;
    if (!nodes.empty() && nodes[0].min_id != kNone) search(0, box_d2(0, p), p, best, best_id, best_d2);
    return best;
  }
  void search(uint32_t node, float node_d2, const float* p, uint32_t& best, uint32_t& best_id, float& best_d2) const {
    // A box at the best distance can only hold a winner with a smaller id: without this, a
    // mesh whose distances all round to one value (squares underflowing at 1e-37 scale) made
    // every search visit the whole tree.
    if (nodes[node].min_id == kNone || node_d2 > best_d2 || (node_d2 == best_d2 && nodes[node].min_id > best_id))
      return;
    if (node >= leaf_base) {
      const uint32_t begin = (node - leaf_base) * kKdLeafSize;
      const uint32_t end = uint32_t(std::min<size_t>(n, begin + kKdLeafSize));
      for (uint32_t i = begin; i < end; ++i) {
        if (clustered[i]) continue;
        const uint32_t t = id_of(i);
        const float d2 = squared_distance(&centroids[3 * size_t(i)], p);
        if (d2 < best_d2 || (d2 == best_d2 && t < best_id)) best = i, best_id = t, best_d2 = d2;
      }
      return;
    }
    // The nearer child first (at equal distance the one with the smaller id), so the other
    // one is more often pruned.
    const uint32_t l = 2 * node + 1, r = 2 * node + 2;
    const float dl = box_d2(l, p), dr = box_d2(r, p);
    if (dl < dr || (dl == dr && nodes[l].min_id <= nodes[r].min_id)) {
      search(l, dl, p, best, best_id, best_d2);
      search(r, dr, p, best, best_id, best_d2);
    } else {
      search(r, dr, p, best, best_id, best_d2);
      search(l, dl, p, best, best_id, best_d2);
    }
  }
};

// Candidate of the growing cluster in its priority bucket: the triangle and its centroid
// (copied, so a bucket scan reads one contiguous array).
struct BucketEntry {
  float x, y, z;
  uint32_t triangle;
};

// Candidate priorities: 0 adds no vertex; 1 + new vertices otherwise, 1 when it holds a vertex
// where it is the last unclustered triangle (0..4).
constexpr uint32_t kPriorityBuckets = 5;

// The grower's state over one split: the triangles in local (compacted welded) ids, their
// centroids, each vertex's unclustered triangles, and the cluster being grown with its
// candidates (the unclustered triangles at its vertices) bucketed by priority. Triangles are
// numbered in the grower's own order (positions): the input order, or for splits of more
// than kNearestScanMaxTriangles the curve order (`id`: position → input index). Every choice
// breaks its ties by input index, so the clusters do not depend on the order.
struct Grower {
  Grower(const TriangleSet& t, std::vector<uint32_t>& s, ClusterSink* k)
      : tris(t), scratch(s), sink(k), n(t.triangle_count()) {}
  const TriangleSet& tris;
  std::vector<uint32_t>& scratch;
  ClusterSink* sink;  // null: the clusters go to `out`
  size_t n;                      // triangles
  std::vector<uint32_t> id;      // per position: its input index (empty: the input order)
  std::vector<uint32_t> local;   // 3 local vertex ids per triangle
  std::vector<float> centroid;   // 3 per triangle
  // Triangles per vertex (CSR: [first[v], first[v + 1]) of adjacency, clustered ones skipped)
  // and how many of them are unclustered (live).
  std::vector<uint32_t> first, live, adjacency;
  CentroidTree tree;
  std::vector<uint8_t> clustered;
  std::vector<uint32_t> in_cluster;  // stamp: index of the cluster using the vertex
  std::vector<uint32_t> joined;      // per vertex: its rank in the cluster using it
  std::vector<BucketEntry> buckets[kPriorityBuckets];
  std::vector<uint8_t> bucket_of;    // per triangle: its bucket, or kNoBucket
  std::vector<uint32_t> slot_of;     // per triangle: its index in that bucket
  std::vector<uint32_t> ids;  // the cluster's triangles (input indices) in order of addition
  std::vector<TriangleSet> out;
  // With a sink: the clusters not yet handed over, as lists (ClusterSink::take_lists).
  std::vector<uint32_t> list_ids, list_ends;
  uint32_t stamp = 0, cluster_vertices = 0;
  float sum[3] = {0, 0, 0};  // of the cluster's triangle centroids
  // False when no corner of the set is a copy of another vertex's position (index_triangles):
  // then a cluster's original vertices are its positions (cluster_vertices), and it is
  // emitted without counting them.
  bool copies = false;

  uint32_t id_of(uint32_t t) const { return id.empty() ? t : id[t]; }
};
constexpr uint8_t kNoBucket = 0xFF;

// Local ids, centroids and the vertex → triangle lists of `g.tris`, in the grower's order
// (the curve order when `along_curve` and the split is large).
void index_triangles(Grower& g, const WeldedMesh& welded, bool along_curve) {
  const Mesh& mesh = *welded.mesh;
  const size_t n = g.n;
  auto centroid_of = [&](const uint32_t* w, float* out) {
    for (int k = 0; k < 3; ++k)
      out[k] = (mesh.positions[3 * size_t(w[0]) + k] + mesh.positions[3 * size_t(w[1]) + k] +
                mesh.positions[3 * size_t(w[2]) + k]) / 3.0f;
  };
  // compact_welded over the triangles in the grower's order (local ids in order of first use
  // there), with the centroids: `corners_of(i)` = the input corners of position i.
  // Welded id per local id (to clear `scratch`): at most one per corner and per welded id,
  // left uninitialized (a leaf chunk's bound is megabytes, mostly untouched).
  const size_t max_local = std::min(3 * n, welded.weld.size());
  const std::unique_ptr<uint32_t[]> welded_of_local(new uint32_t[max_local]);
  uint32_t vcount = 0;
  bool copy = false;
  g.local.resize(3 * n);
  g.centroid.resize(3 * n);
  auto compact = [&](auto&& corners_of, auto&& centroid_at) {
    for (size_t i = 0; i < n; ++i) {
      const uint32_t* corners = corners_of(i);
      uint32_t w[3];
      for (int k = 0; k < 3; ++k) {
        w[k] = welded.weld[corners[k]];
        copy |= w[k] != corners[k];
        if (g.scratch[w[k]] == kNone) {
          g.scratch[w[k]] = vcount;
          welded_of_local[vcount++] = w[k];
        }
        g.local[3 * i + k] = g.scratch[w[k]];
      }
      centroid_at(i, w);
    }
  };
  if (along_curve && n > kNearestScanMaxTriangles) {
    std::vector<float> input_centroid(3 * n);
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (size_t t = 0; t < n; ++t) {
      const uint32_t* c = &g.tris.corners[3 * t];
      const uint32_t w[3] = {welded.weld[c[0]], welded.weld[c[1]], welded.weld[c[2]]};
      float* p = &input_centroid[3 * t];
      centroid_of(w, p);
      for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    }
    g.id = curve_order(input_centroid.data(), n, lo, hi);
    compact([&](size_t i) { return &g.tris.corners[3 * size_t(g.id[i])]; },
            [&](size_t i, const uint32_t*) {
              std::copy_n(&input_centroid[3 * size_t(g.id[i])], 3, &g.centroid[3 * i]);
            });
  } else {
    compact([&](size_t i) { return &g.tris.corners[3 * i]; },
            [&](size_t i, const uint32_t* w) { centroid_of(w, &g.centroid[3 * i]); });
  }
  for (uint32_t v = 0; v < vcount; ++v) g.scratch[welded_of_local[v]] = kNone;
  g.copies = copy;
  g.first.assign(vcount + 1, 0);
  g.live.assign(vcount, 0);
  g.adjacency.resize(3 * n);
  for (uint32_t v : g.local) ++g.live[v];
  for (size_t v = 0; v < vcount; ++v) g.first[v + 1] = g.first[v] + g.live[v];
  {
    std::vector<uint32_t> fill(g.first.begin(), g.first.end() - 1);
    for (uint32_t t = 0; t < n; ++t)
      for (int k = 0; k < 3; ++k) g.adjacency[fill[g.local[3 * size_t(t) + k]]++] = t;
  }
  g.clustered.assign(n, 0);
  g.in_cluster.assign(vcount, kNone);
  g.joined.resize(vcount);
  g.bucket_of.assign(n, kNoBucket);
  g.slot_of.resize(n);
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

void leave_bucket(Grower& g, uint32_t t) {
  const uint8_t b = g.bucket_of[t];
  if (b == kNoBucket) return;
  std::vector<BucketEntry>& bucket = g.buckets[b];
  const uint32_t slot = g.slot_of[t];
  bucket[slot] = bucket.back();
  g.slot_of[bucket[slot].triangle] = slot;
  bucket.pop_back();
  g.bucket_of[t] = kNoBucket;
}

// (Re)files candidate t under its current priority.
void file_candidate(Grower& g, uint32_t t) {
  const uint32_t p = priority_of(g, t);
  if (g.bucket_of[t] == p) return;
  leave_bucket(g, t);
  g.bucket_of[t] = uint8_t(p);
  g.slot_of[t] = uint32_t(g.buckets[p].size());
  const float* c = &g.centroid[3 * size_t(t)];
  g.buckets[p].push_back({c[0], c[1], c[2], t});
}

// The grown cluster emitted; the next one starts empty.
void finish_cluster(Grower& g) {
  // (The nearest triangle joins a cluster without the vertex check: cluster_vertices can pass
  // the limit, and emit_cluster then bisects.)
  const bool fits = !g.copies && g.ids.size() <= kMaxClusterTriangles && g.cluster_vertices <= kMaxClusterVertices;
  if (g.ids.empty()) {
  } else if (g.sink) {
    const uint32_t offset = uint32_t(g.list_ids.size());
    g.list_ids.insert(g.list_ids.end(), g.ids.begin(), g.ids.end());
    if (fits)
      g.list_ends.push_back(uint32_t(g.list_ids.size()));
    else
      cluster_pieces(g.tris, g.ids.data(), g.ids.size(), g.scratch, offset, g.list_ends);
  } else if (fits) {
    append_cluster(g.tris, g.ids.data(), g.ids.size(), g.out);
  } else {
    emit_cluster(g.tris, g.ids.data(), g.ids.size(), g.scratch, g.out);
  }
  g.ids.clear();
  for (std::vector<BucketEntry>& bucket : g.buckets) {
    for (const BucketEntry& e : bucket) g.bucket_of[e.triangle] = kNoBucket;
    bucket.clear();
  }
  ++g.stamp;
  g.cluster_vertices = 0;
  g.sum[0] = g.sum[1] = g.sum[2] = 0;
}

// Triangle t joins the cluster: it leaves its vertices' lists and its bucket; the triangles
// at its new vertices become candidates, and those whose priority changed (a vertex joined,
// or one of theirs now has a single unclustered triangle) are refiled.
void add_triangle(Grower& g, uint32_t t) {
  g.clustered[t] = 1;
  g.tree.remove(t);
  leave_bucket(g, t);
  g.ids.push_back(g.id_of(t));
  for (int k = 0; k < 3; ++k) g.sum[k] += g.centroid[3 * size_t(t) + k];
  const uint32_t* c = &g.local[3 * size_t(t)];
  // t stays in its vertices' lists, skipped from now on as clustered (finding it to remove it
  // was a sixth of the grower's time); `live` counts the others.
  for (int k = 0; k < 3; ++k) --g.live[c[k]];
  for (int k = 0; k < 3; ++k) {
    const uint32_t v = c[k];
    const uint32_t *list = &g.adjacency[g.first[v]], *end = &g.adjacency[0] + g.first[v + 1];
    // A new vertex refiles all its unclustered triangles; an old one its last one, now
    // dangling. Refiling order does not matter: a triangle's bucket is its priority once all
    // three vertices are updated, and best_candidate's choice does not depend on the order
    // within a bucket. (One call site: the compiler inlines file_candidate, the grower's most
    // frequent step.)
    if (g.in_cluster[v] != g.stamp) {
      g.in_cluster[v] = g.stamp;
      g.joined[v] = g.cluster_vertices++;
    } else if (g.live[v] == 1) {
      while (g.clustered[*list]) ++list;
      end = list + 1;
    } else {
      continue;
    }
    for (; list != end; ++list)
      if (!g.clustered[*list]) file_candidate(g, *list);
  }
}

// Tie order of two equally near candidates (common on regular meshes: grids, UV spheres): the
// one at the cluster's earliest vertex, then the smaller id; meshopt 0.18 keeps the first it
// meets scanning the cluster's vertices in order, so this is its order up to the order of a
// vertex's triangles.
uint32_t earliest_vertex(const Grower& g, uint32_t t) {
  const uint32_t* c = &g.local[3 * size_t(t)];
  uint32_t r = UINT32_MAX;
  for (int k = 0; k < 3; ++k)
    if (g.in_cluster[c[k]] == g.stamp) r = std::min(r, g.joined[c[k]]);
  return r;
}
bool breaks_tie(const Grower& g, uint32_t t, uint32_t best) {
  if (best == kNone) return true;
  const uint32_t rt = earliest_vertex(g, t), rb = earliest_vertex(g, best);
  return rt < rb || (rt == rb && g.id_of(t) < g.id_of(best));
}

// The best candidate: lowest priority, then nearest the cluster's current centroid (ties:
// breaks_tie); kNone if there is none.
uint32_t best_candidate(const Grower& g) {
  const float inv = 1.0f / float(g.ids.size());
  const float cx = g.sum[0] * inv, cy = g.sum[1] * inv, cz = g.sum[2] * inv;
  for (const std::vector<BucketEntry>& bucket : g.buckets) {
    if (bucket.empty()) continue;
    uint32_t best = kNone;
    float best_d2 = FLT_MAX;
    for (const BucketEntry& e : bucket) {
      const float d2 = (e.x - cx) * (e.x - cx) + (e.y - cy) * (e.y - cy) + (e.z - cz) * (e.z - cz);
      if (d2 < best_d2 || (d2 == best_d2 && breaks_tie(g, e.triangle, best))) best = e.triangle, best_d2 = d2;
    }
    return best;
  }
  return kNone;
}

// The unclustered triangle nearest the cluster's centroid (ties: smaller input index; a scan,
// or the tree built on first use for large splits); kNone when none is left.
uint32_t nearest_to_cluster(Grower& g) {
  float c[3];
  for (int k = 0; k < 3; ++k) c[k] = g.sum[k] / float(g.ids.size());
  if (g.n > kNearestScanMaxTriangles) {
    if (!g.tree.built()) g.tree.build(g.centroid.data(), g.n, g.clustered.data(), g.id.empty() ? nullptr : g.id.data());
    return g.tree.nearest(c);
  }
  uint32_t best = kNone;
  float best_d2 = FLT_MAX;
  for (uint32_t t = 0; t < g.n; ++t) {
    if (g.clustered[t]) continue;
    const float d2 = squared_distance(&g.centroid[3 * size_t(t)], c);
    if (d2 < best_d2 || (d2 == best_d2 && best != kNone && g.id_of(t) < g.id_of(best))) best = t, best_d2 = d2;
  }
  return best;
}

// The first triangle: the one whose centroid is nearest the origin (ties: smaller input
// index; input index 0 when no distance is below FLT_MAX), where meshopt_buildMeshlets 0.18
// starts (its empty cluster's centroid is the origin).
uint32_t first_seed(const Grower& g) {
  const float origin[3] = {0, 0, 0};
  uint32_t next = kNone, next_id = 0;
  float best_d2 = FLT_MAX;
  for (uint32_t t = 0; t < g.n; ++t) {
    const float d2 = squared_distance(&g.centroid[3 * size_t(t)], origin);
    const uint32_t id = g.id_of(t);
    if (d2 < best_d2 || (d2 == best_d2 && id < next_id)) next = t, next_id = id, best_d2 = d2;
  }
  if (next != kNone) return next;
  for (uint32_t t = 0;; ++t)
    if (g.id_of(t) == 0) return t;
}

// Hands the grown clusters to the sink (when given) once there are at least `batch` of them.
void hand_over(Grower& g, size_t batch) {
  if (!g.sink || g.list_ends.empty() || g.list_ends.size() < batch) return;
  g.sink->take_lists(g.tris, g.list_ids.data(), g.list_ends.data(), g.list_ends.size());
  g.list_ids.clear();
  g.list_ends.clear();
}

}  // namespace

std::vector<TriangleSet> split_grow(const WeldedMesh& welded, const TriangleSet& tris, std::vector<uint32_t>& scratch,
                                   bool along_curve, ClusterSink* sink) {
  if (tris.triangle_count() == 0) return {};
  Grower g(tris, scratch, sink);
  index_triangles(g, welded, along_curve);
  uint32_t next = first_seed(g);
  for (size_t done = 0; next != kNone;) {
    add_triangle(g, next);
    if (++done == g.n) break;
    next = best_candidate(g);
    const bool full = g.ids.size() >= kMaxClusterTriangles ||
                      (next != kNone && g.cluster_vertices + new_vertices(g, next) > kMaxClusterVertices);
    if (full) {
      // The full cluster's best candidate starts the next one (meshopt 0.18 moves it there);
      // with none, the unclustered triangle nearest the full cluster's centroid.
      const uint32_t nearest = next == kNone ? nearest_to_cluster(g) : kNone;
      finish_cluster(g);
      hand_over(g, kSinkBatchClusters);
      if (next == kNone) next = nearest;
    } else if (next == kNone) {
      next = nearest_to_cluster(g);
    }
  }
  finish_cluster(g);
  hand_over(g, 1);
  return std::move(g.out);
}

}  // namespace vgeo::build_detail
