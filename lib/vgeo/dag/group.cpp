// Grouping clusters of one level with METIS (spec/dag.md §Grouping): graph nodes are
// clusters (weight = triangles), edge weight = number of shared welded triangle edges,
// plus weak spatial edges so islands are grouped with their neighbours.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"DAG: Which clusters to group?" (a
// minimum edge cut locks the fewest edges); Karypis, Kumar, "A Fast and High Quality Multilevel
// Scheme for Partitioning Irregular Graphs", SIAM J. Sci. Comput. 20(1), 1998 (METIS).
#include <metis.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <mutex>

#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/cluster_dag.h"

namespace vgeo::build_detail {

namespace {

struct WeightedEdge {
  uint32_t a, b;
  int weight;
  bool operator<(const WeightedEdge& o) const { return a != o.a ? a < o.a : b < o.b; }
};

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

std::vector<std::vector<uint32_t>> group_clusters(const std::vector<const TriangleSet*>& clusters,
                                                  const std::vector<std::vector<uint64_t>>& cluster_open_edges,
                                                  const std::vector<Sphere>& bounds, uint32_t target_clusters) {
  size_t n = clusters.size();
  std::vector<std::vector<uint32_t>> groups;
  if (n == 0) return groups;
  size_t nparts = (n + target_clusters - 1) / target_clusters;
  if (nparts <= 1) {  // METIS misbehaves for nparts = 1; the answer is known anyway
    groups.emplace_back(n);
    for (size_t i = 0; i < n; ++i) groups[0][i] = uint32_t(i);
    return groups;
  }

  // Shared welded edges: (edge key, cluster) for edges open inside their cluster.
  std::vector<std::pair<uint64_t, uint32_t>> open_edges;
  {
    size_t total = 0;
    for (const auto& e : cluster_open_edges) total += e.size();
    open_edges.reserve(total);
  }
  for (size_t c = 0; c < n; ++c)
    for (uint64_t k : cluster_open_edges[c]) open_edges.push_back({k, uint32_t(c)});
  std::sort(open_edges.begin(), open_edges.end());
  std::vector<WeightedEdge> edges;
  for (size_t i = 0; i < open_edges.size();) {
    size_t j = i;
    while (j < open_edges.size() && open_edges[j].first == open_edges[i].first) ++j;
    // A welded edge is shared by 2 clusters on a manifold; non-manifold fans link all
    // pairs up to a small bound, then consecutive ones (keeps the graph linear in size).
    bool fan = j - i > 4;
    for (size_t x = i; x < j; ++x)
      for (size_t y = x + 1; y < (fan ? std::min(j, x + 2) : j); ++y) {
        uint32_t a = open_edges[x].second, b = open_edges[y].second;
        if (a == b) continue;
        edges.push_back({a, b, 1});
        edges.push_back({b, a, 1});
      }
    i = j;
  }
  std::vector<std::pair<uint64_t, uint32_t>>().swap(open_edges);
  auto merge_edges = [](std::vector<WeightedEdge>& e) {
    std::sort(e.begin(), e.end());
    size_t out = 0;
    for (size_t i = 0; i < e.size();) {
      size_t j = i;
      int w = 0;
      while (j < e.size() && e[j].a == e[i].a && e[j].b == e[i].b) w += e[j++].weight;
      e[out++] = {e[i].a, e[i].b, w};
      i = j;
    }
    e.resize(out);
  };
  merge_edges(edges);

  // Weak spatial edges between clusters near in Morton order that share no edge.
  {
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
    // Adjacency lookup: edges are sorted by (a, b).
    std::vector<size_t> first(n + 1, 0);
    for (const WeightedEdge& e : edges) ++first[e.a + 1];
    for (size_t i = 0; i < n; ++i) first[i + 1] += first[i];
    auto adjacent = [&](uint32_t a, uint32_t b) {
      auto lo_it = edges.begin() + first[a], hi_it = edges.begin() + first[a + 1];
      return std::binary_search(lo_it, hi_it, WeightedEdge{a, b, 0});
    };
    std::vector<WeightedEdge> spatial;
    for (size_t i = 0; i < n; ++i) {
      uint32_t c = order[i].second;
      std::vector<std::pair<double, uint32_t>> cand;
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
    // Deduplicate spatial edges (both ends may pick each other) before adding them.
    std::sort(spatial.begin(), spatial.end());
    spatial.erase(std::unique(spatial.begin(), spatial.end(),
                              [](const WeightedEdge& x, const WeightedEdge& y) { return x.a == y.a && x.b == y.b; }),
                  spatial.end());
    edges.insert(edges.end(), spatial.begin(), spatial.end());
    merge_edges(edges);
  }

  std::vector<idx_t> xadj(n + 1, 0), adjncy(edges.size()), adjwgt(edges.size()), vwgt(n);
  for (size_t i = 0; i < edges.size(); ++i) {
    ++xadj[edges[i].a + 1];
    adjncy[i] = idx_t(edges[i].b);
    adjwgt[i] = idx_t(edges[i].weight);
  }
  for (size_t i = 0; i < n; ++i) {
    xadj[i + 1] += xadj[i];
    vwgt[i] = idx_t(std::max<size_t>(1, clusters[i]->triangle_count()));
  }
  std::vector<idx_t> part(n, 0);
  idx_t nvtxs = idx_t(n), ncon = 1, np = idx_t(nparts), objval = 0;
  idx_t options[METIS_NOPTIONS];
  set_metis_options(options);
  int rc;
  {
    std::lock_guard<std::mutex> lock(metis_mutex());
    rc = METIS_PartGraphKway(&nvtxs, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr, adjwgt.data(), &np,
                             nullptr, nullptr, options, &objval, part.data());
  }
  groups.assign(nparts, {});
  if (rc == METIS_OK) {
    for (size_t i = 0; i < n; ++i) groups[size_t(part[i]) < nparts ? size_t(part[i]) : 0].push_back(uint32_t(i));
  } else {
    // Fallback (METIS failed, e.g. out of memory): consecutive runs in Morton-free index order.
    for (size_t i = 0; i < n; ++i) groups[i / target_clusters].push_back(uint32_t(i));
  }
  groups.erase(std::remove_if(groups.begin(), groups.end(), [](const auto& g) { return g.empty(); }), groups.end());
  return groups;
}

std::mutex& metis_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace vgeo::build_detail
