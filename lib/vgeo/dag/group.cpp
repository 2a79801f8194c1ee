// Grouping clusters of one level (spec/dag.md §Grouping): the cluster graph — nodes are
// clusters (weight = triangles), edge weight = number of shared welded triangle edges, plus
// weak spatial edges so islands are grouped with their neighbours — partitioned by the greedy
// partitioner (cluster_partition.cpp) or, for measuring, by METIS k-way.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"DAG: Which clusters to group?" (a
// minimum edge cut locks the fewest edges); Karypis, Kumar, "A Fast and High Quality Multilevel
// Scheme for Partitioning Irregular Graphs", SIAM J. Sci. Comput. 20(1), 1998 (METIS, GroupMethod::kMetis).
#include <dlfcn.h>
#include <metis.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <mutex>
#include <string>

#include "vgeo/core/error.h"
#include "vgeo/core/shared_library.h"
#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/cluster_dag.h"

namespace vgeo::build_detail {

namespace {

struct WeightedEdge {
  uint32_t a, b;
  int weight;
  bool operator<(const WeightedEdge& o) const { return a != o.a ? a < o.a : b < o.b; }
};

// Bits per pass of the open edges' radix sort: 2,048 counters (8 KiB) stay in L1.
constexpr uint32_t kEdgeRadixBits = 11;

// An open edge of a cluster: its welded edge key (compressed, below) and the cluster.
struct OpenEdge {
  uint64_t key;
  uint32_t cluster;
};

// Every cluster's open edges sorted by key, then cluster. The edges are listed in cluster
// order, so a stable sort by key alone gives that order: an LSD radix sort of the keys
// compressed to (high << bits of the largest low) | low, which keeps their order and
// equality, over as many passes as the compressed keys have bits (40 on a 2^20-vertex mesh:
// 4 passes instead of a comparison sort of the pairs).
std::vector<OpenEdge> sorted_open_edges(const std::vector<std::vector<uint64_t>>& cluster_open_edges) {
  size_t total = 0;
  uint64_t max_high = 0, max_low = 0;
  for (const auto& keys : cluster_open_edges) {
    total += keys.size();
    for (uint64_t k : keys) max_high = std::max(max_high, k >> 32), max_low = std::max(max_low, k & 0xFFFFFFFFu);
  }
  const uint32_t low_bits = uint32_t(std::bit_width(max_low)), key_bits = low_bits + uint32_t(std::bit_width(max_high));
  std::vector<OpenEdge> edges, sorted;
  edges.reserve(total);
  for (size_t c = 0; c < cluster_open_edges.size(); ++c)
    for (uint64_t k : cluster_open_edges[c]) edges.push_back({((k >> 32) << low_bits) | (k & 0xFFFFFFFFu), uint32_t(c)});
  sorted.resize(edges.size());
  constexpr uint32_t kBuckets = 1u << kEdgeRadixBits;
  for (uint32_t shift = 0; shift < key_bits; shift += kEdgeRadixBits) {
    uint32_t start[kBuckets + 1] = {};
    for (const OpenEdge& e : edges) ++start[((e.key >> shift) & (kBuckets - 1)) + 1];
    for (uint32_t b = 0; b < kBuckets; ++b) start[b + 1] += start[b];
    for (const OpenEdge& e : edges) sorted[start[(e.key >> shift) & (kBuckets - 1)]++] = e;
    edges.swap(sorted);
  }
  return edges;
}

// Rows of (neighbour, weight) pairs: row a = [first[a], first[a + 1]).
struct WeightedRows {
  std::vector<size_t> first;
  std::vector<uint32_t> to;
  std::vector<int> weight;
};

// Per cluster, the clusters it shares welded edges with and how many, neighbours ascending
// (the same graph as a sort of every (a, b) use and a sum of equal pairs, built by rows).
WeightedRows shared_edge_rows(const std::vector<std::vector<uint64_t>>& cluster_open_edges) {
  const size_t n = cluster_open_edges.size();
  const std::vector<OpenEdge> open_edges = sorted_open_edges(cluster_open_edges);
  // Pairs (a, b), one per use: a welded edge is shared by 2 clusters on a manifold;
  // non-manifold fans link all pairs up to a small bound, then consecutive ones (keeps the
  // graph linear in size).
  auto for_each_pair = [&](auto&& fn) {
    for (size_t i = 0; i < open_edges.size();) {
      size_t j = i;
      while (j < open_edges.size() && open_edges[j].key == open_edges[i].key) ++j;
      const bool fan = j - i > 4;
      for (size_t x = i; x < j; ++x)
        for (size_t y = x + 1; y < (fan ? std::min(j, x + 2) : j); ++y) {
          const uint32_t a = open_edges[x].cluster, b = open_edges[y].cluster;
          if (a == b) continue;
          fn(a, b);
          fn(b, a);
        }
      i = j;
    }
  };
  std::vector<size_t> fill(n + 1, 0);
  for_each_pair([&](uint32_t a, uint32_t) { ++fill[a + 1]; });
  for (size_t i = 0; i < n; ++i) fill[i + 1] += fill[i];
  std::vector<uint32_t> uses(fill[n]);
  std::vector<size_t> first = fill;
  for_each_pair([&](uint32_t a, uint32_t b) { uses[fill[a]++] = b; });
  WeightedRows rows;
  rows.first.assign(n + 1, 0);
  rows.to.reserve(uses.size() / 2);
  rows.weight.reserve(uses.size() / 2);
  for (size_t a = 0; a < n; ++a) {
    std::sort(uses.begin() + first[a], uses.begin() + first[a + 1]);
    for (size_t i = first[a]; i < first[a + 1];) {
      size_t j = i;
      while (j < first[a + 1] && uses[j] == uses[i]) ++j;
      rows.to.push_back(uses[i]);
      rows.weight.push_back(int(j - i));
      i = j;
    }
    rows.first[a + 1] = rows.to.size();
  }
  return rows;
}

// Weak spatial edges between clusters near in Morton order that share no edge (both
// directions, deduplicated, sorted by (a, b)).
std::vector<WeightedEdge> spatial_edges(const WeightedRows& shared, const std::vector<Sphere>& bounds) {
  const size_t n = bounds.size();
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (const Sphere& s : bounds)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(s.center[k]));
      hi[k] = std::max(hi[k], double(s.center[k]));
    }
  double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-30});
  std::vector<std::pair<uint32_t, uint32_t>> order(n);
  for (size_t c = 0; c < n; ++c) {
    uint32_t q[3];
    for (int k = 0; k < 3; ++k)
      q[k] = uint32_t(std::clamp((double(bounds[c].center[k]) - lo[k]) / extent * 1023.0, 0.0, 1023.0));
    order[c] = {morton_code(q[0], q[1], q[2]), uint32_t(c)};
  }
  std::sort(order.begin(), order.end());
  auto adjacent = [&](uint32_t a, uint32_t b) {
    return std::binary_search(shared.to.begin() + shared.first[a], shared.to.begin() + shared.first[a + 1], b);
  };
  std::vector<WeightedEdge> spatial;
  std::vector<std::pair<double, uint32_t>> cand;
  for (size_t i = 0; i < n; ++i) {
    uint32_t c = order[i].second;
    cand.clear();
    size_t from = i >= kSpatialWindow ? i - kSpatialWindow : 0, to = std::min(n, i + kSpatialWindow + 1);
    for (size_t j = from; j < to; ++j) {
      uint32_t d = order[j].second;
      if (d == c || adjacent(c, d)) continue;
      cand.push_back({distance_d(bounds[c].center, bounds[d].center), d});
    }
    std::sort(cand.begin(), cand.end());
    for (size_t k = 0; k < cand.size() && k < kSpatialNeighbors; ++k) {
      spatial.push_back({c, cand[k].second, kSpatialEdgeWeight});
      spatial.push_back({cand[k].second, c, kSpatialEdgeWeight});
    }
  }
  // Both ends may pick each other.
  std::sort(spatial.begin(), spatial.end());
  spatial.erase(std::unique(spatial.begin(), spatial.end(),
                            [](const WeightedEdge& x, const WeightedEdge& y) { return x.a == y.a && x.b == y.b; }),
                spatial.end());
  return spatial;
}

// The shared-edge rows and the spatial edges merged row by row (weights of equal pairs
// summed; none are equal, spatial edges join only non-adjacent clusters).
ClusterAdjacency cluster_graph(const std::vector<std::vector<uint64_t>>& cluster_open_edges,
                               const std::vector<Sphere>& bounds) {
  const size_t n = cluster_open_edges.size();
  const WeightedRows shared = shared_edge_rows(cluster_open_edges);
  const std::vector<WeightedEdge> spatial = spatial_edges(shared, bounds);
  ClusterAdjacency g;
  g.first.assign(n + 1, 0);
  g.to.reserve(shared.to.size() + spatial.size());
  g.weight.reserve(shared.to.size() + spatial.size());
  size_t s = 0;
  for (size_t a = 0; a < n; ++a) {
    size_t i = shared.first[a];
    const size_t end = shared.first[a + 1];
    while (i < end || (s < spatial.size() && spatial[s].a == a)) {
      const bool take_spatial = s < spatial.size() && spatial[s].a == a && (i == end || spatial[s].b <= shared.to[i]);
      const bool take_shared = i < end && (!take_spatial || shared.to[i] == spatial[s].b);
      const uint32_t b = take_shared ? shared.to[i] : spatial[s].b;
      int w = 0;
      if (take_shared) w += shared.weight[i++];
      if (take_spatial) w += spatial[s++].weight;
      g.to.push_back(b);
      g.weight.push_back(uint32_t(w));
    }
    g.first[a + 1] = uint32_t(g.to.size());
  }
  return g;
}

}  // namespace

std::vector<std::vector<uint32_t>> spatial_blocks(const std::vector<Vec3>& centres, size_t max_items) {
  std::vector<std::vector<uint32_t>> blocks;
  std::vector<uint32_t> items(centres.size());
  for (size_t i = 0; i < items.size(); ++i) items[i] = uint32_t(i);
  if (items.empty()) return blocks;
  max_items = std::max<size_t>(max_items, 1);
  // Explicit stack of [begin, end) ranges, upper half pushed first so the lower half
  // comes out first.
  std::vector<std::pair<size_t, size_t>> stack{{0, items.size()}};
  while (!stack.empty()) {
    auto [begin, end] = stack.back();
    stack.pop_back();
    if (end - begin <= max_items) {
      std::vector<uint32_t> block(items.begin() + begin, items.begin() + end);
      std::sort(block.begin(), block.end());
      blocks.push_back(std::move(block));
      continue;
    }
    float lo[3] = {centres[items[begin]].x, centres[items[begin]].y, centres[items[begin]].z};
    float hi[3] = {lo[0], lo[1], lo[2]};
    for (size_t i = begin; i < end; ++i)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], centres[items[i]][k]);
        hi[k] = std::max(hi[k], centres[items[i]][k]);
      }
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (double(hi[k]) - lo[k] > double(hi[axis]) - lo[axis]) axis = k;
    size_t mid = begin + (end - begin) / 2;
    std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end, [&](uint32_t a, uint32_t b) {
      float ca = centres[a][axis], cb = centres[b][axis];
      return ca < cb || (ca == cb && a < b);
    });
    stack.push_back({mid, end});
    stack.push_back({begin, mid});
  }
  return blocks;
}

namespace {

// METIS k-way over the same graph (GroupMethod::kMetis): each node's group, or an empty
// vector where METIS failed.
std::vector<uint32_t> partition_clusters_metis(const ClusterAdjacency& graph, const std::vector<uint32_t>& weight,
                                               size_t part_count) {
  const size_t n = weight.size();
  std::vector<idx_t> xadj(graph.first.begin(), graph.first.end()), adjncy(graph.to.begin(), graph.to.end()),
      adjwgt(graph.weight.begin(), graph.weight.end()), vwgt(weight.begin(), weight.end());
  std::vector<idx_t> part(n, 0);
  idx_t nvtxs = idx_t(n), ncon = 1, np = idx_t(part_count), objval = 0;
  idx_t options[METIS_NOPTIONS];
  set_metis_options(options);
  int rc;
  {
    std::lock_guard<std::mutex> lock(metis_mutex());
    rc = metis_functions().part_graph_kway(&nvtxs, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr,
                                           adjwgt.data(), &np, nullptr, nullptr, options, &objval, part.data());
  }
  if (rc != METIS_OK) return {};
  std::vector<uint32_t> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = size_t(part[i]) < part_count ? uint32_t(part[i]) : 0;
  return out;
}

}  // namespace

std::vector<std::vector<uint32_t>> group_clusters(const std::vector<const TriangleSet*>& clusters,
                                                  const std::vector<std::vector<uint64_t>>& cluster_open_edges,
                                                  const std::vector<Sphere>& bounds, uint32_t target_clusters,
                                                  GroupMethod method) {
  size_t n = clusters.size();
  std::vector<std::vector<uint32_t>> groups;
  if (n == 0) return groups;
  size_t nparts = (n + target_clusters - 1) / target_clusters;
  if (nparts <= 1) {  // one group: the answer is known (and METIS misbehaves for nparts = 1)
    groups.emplace_back(n);
    for (size_t i = 0; i < n; ++i) groups[0][i] = uint32_t(i);
    return groups;
  }

  const ClusterAdjacency graph = cluster_graph(cluster_open_edges, bounds);
  std::vector<uint32_t> weight(n);
  for (size_t i = 0; i < n; ++i) weight[i] = uint32_t(std::max<size_t>(1, clusters[i]->triangle_count()));
  std::vector<uint32_t> part = method == GroupMethod::kMetis ? partition_clusters_metis(graph, weight, nparts)
                                                             : partition_clusters(graph, weight, nparts);
  if (part.empty()) {
    // Fallback (METIS failed, e.g. out of memory): consecutive runs in index order.
    part.resize(n);
    for (size_t i = 0; i < n; ++i) part[i] = uint32_t(i / target_clusters);
  }
  for (size_t i = 0; i < n; ++i) {
    if (part[i] >= groups.size()) groups.resize(part[i] + 1);
    groups[part[i]].push_back(uint32_t(i));
  }
  groups.erase(std::remove_if(groups.begin(), groups.end(), [](const auto& g) { return g.empty(); }), groups.end());
  return groups;
}

std::mutex& metis_mutex() {
  static std::mutex m;
  return m;
}

const MetisFunctions& metis_functions() {
  static constexpr const char* kMetisLibrary = "libmetis.so.5";  // METIS 5's ABI name (Debian: libmetis5)
  static std::once_flag once;
  static MetisFunctions functions;
  static std::string failure;
  std::call_once(once, [] {
    const OpenedLibrary opened = open_shared_library(kMetisLibrary, "METIS");
    if (!opened.handle) {
      failure = opened.failure;
      return;
    }
    void* library = opened.handle;
    MetisFunctions f;
    f.set_default_options = reinterpret_cast<decltype(f.set_default_options)>(dlsym(library, "METIS_SetDefaultOptions"));
    f.part_graph_kway = reinterpret_cast<decltype(f.part_graph_kway)>(dlsym(library, "METIS_PartGraphKway"));
    f.part_graph_recursive =
        reinterpret_cast<decltype(f.part_graph_recursive)>(dlsym(library, "METIS_PartGraphRecursive"));
    if (!f.set_default_options || !f.part_graph_kway || !f.part_graph_recursive)
      failure = std::string(kMetisLibrary) + " lacks a METIS 5 entry point";
    else
      functions = f;
  });
  if (!failure.empty())
    fail("MODULE_UNAVAILABLE", "metis", failure + " (the METIS grouping and split need libmetis5; tools/setup installs it)",
         kExitUsage);
  return functions;
}

}  // namespace vgeo::build_detail
