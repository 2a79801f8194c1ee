// The greedy cluster partitioner (lib/vgeo/dag/cluster_partition.cpp, spec/dag.md §Grouping).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "vgeo/core/thread_pool.h"

#include "vgeo/dag/build_internal.h"

namespace vgeo {
namespace {

using build_detail::ClusterAdjacency;
using build_detail::partition_clusters;
using build_detail::TriangleSet;

// A side × side grid of clusters for group_clusters: neighbours share `shared` welded edges,
// every 7th cluster is an island (no shared edge: only spatial edges reach it), every 13th
// shares a fan edge with its next 5 clusters (a non-manifold edge of 6 uses), each has a few
// open edges of its own (mesh border); keys in a scrambled order per cluster, vertex ids
// scrambled so the keys' high and low halves both vary.
struct ClusterGrid {
  std::vector<TriangleSet> sets;
  std::vector<const TriangleSet*> clusters;
  std::vector<std::vector<uint64_t>> open_edges;
  std::vector<Sphere> bounds;
};
ClusterGrid cluster_grid(uint32_t side, uint32_t shared) {
  ClusterGrid g;
  const uint32_t n = side * side;
  std::mt19937 rng(7);
  uint32_t next_vertex = 0;
  auto fresh_edge = [&] {
    const uint32_t a = (next_vertex++ * 2654435761u) % 1000003u, b = (next_vertex++ * 2654435761u) % 1000003u;
    return build_detail::edge_key(a, b);
  };
  g.open_edges.resize(n);
  auto island = [](uint32_t c) { return c % 7 == 3; };
  for (uint32_t c = 0; c < n; ++c) {
    const uint32_t x = c % side, y = c / side;
    for (uint32_t d : {x + 1 < side ? c + 1 : c, y + 1 < side ? c + side : c}) {
      if (d == c || island(c) || island(d)) continue;
      for (uint32_t k = 0; k < shared; ++k) {
        const uint64_t e = fresh_edge();
        g.open_edges[c].push_back(e);
        g.open_edges[d].push_back(e);
      }
    }
    if (c % 13 == 0 && c + 5 < n) {
      const uint64_t e = fresh_edge();
      for (uint32_t d = c; d <= c + 5; ++d) g.open_edges[d].push_back(e);
    }
    for (uint32_t k = 0; k < 3; ++k) g.open_edges[c].push_back(fresh_edge());
  }
  g.sets.resize(n);
  g.bounds.resize(n);
  std::uniform_real_distribution<float> jitter(-0.2f, 0.2f);
  for (uint32_t c = 0; c < n; ++c) {
    std::shuffle(g.open_edges[c].begin(), g.open_edges[c].end(), rng);
    g.sets[c].materials.resize(100 + c % 29);  // uneven weights, as at coarse levels
    g.bounds[c].center = Vec3{float(c % side) + jitter(rng), float(c / side) + jitter(rng), jitter(rng)};
    g.bounds[c].radius = 0.7f;
  }
  for (const TriangleSet& t : g.sets) g.clusters.push_back(&t);
  return g;
}

// The grouping of a level of one block runs its edge sort, pair rows and spatial edges in
// tasks on the block's pool when the block is large (kParallelEdgeUses, kParallelGraphClusters):
// the same groups, and the same sorted edge uses, as on one thread.
TEST(ClusterGrouping, PoolTasksGiveTheOneThreadGroups) {
  const ClusterGrid g = cluster_grid(64, 10);  // 4,096 clusters, ~95,000 edge uses
  size_t uses = 0;
  for (const auto& keys : g.open_edges) uses += keys.size();
  ASSERT_GE(uses, size_t(1) << 16);
  const build_detail::SortedEdgeUses serial = build_detail::sorted_edge_uses(g.open_edges, nullptr);
  // One thread: what a sort of the (key, list) pairs gives.
  std::vector<std::pair<uint64_t, uint32_t>> pairs;
  for (uint32_t c = 0; c < g.open_edges.size(); ++c)
    for (uint64_t e : g.open_edges[c]) pairs.push_back({e, c});
  std::sort(pairs.begin(), pairs.end());
  ASSERT_EQ(serial.uses.size(), pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    ASSERT_EQ(serial.edge(i), pairs[i].first) << i;
    ASSERT_EQ(serial.uses[i].list, pairs[i].second) << i;
  }
  const std::vector<std::vector<uint32_t>> one_thread =
      build_detail::group_clusters(g.clusters, g.open_edges, g.bounds, 16, build_detail::GroupMethod::kGreedy, nullptr);
  EXPECT_GE(one_thread.size(), size_t(4096 / 16 * 3 / 4));
  for (unsigned threads : {2u, 3u, 5u}) {
    ThreadPool pool(threads);
    const build_detail::SortedEdgeUses parallel = build_detail::sorted_edge_uses(g.open_edges, &pool);
    ASSERT_EQ(parallel.uses.size(), serial.uses.size());
    for (size_t i = 0; i < serial.uses.size(); ++i) {
      ASSERT_EQ(parallel.edge(i), serial.edge(i)) << threads << " threads, use " << i;
      ASSERT_EQ(parallel.uses[i].list, serial.uses[i].list) << threads << " threads, use " << i;
    }
    EXPECT_EQ(build_detail::group_clusters(g.clusters, g.open_edges, g.bounds, 16, build_detail::GroupMethod::kGreedy,
                                           &pool),
              one_thread)
        << threads << " threads";
  }
}

// A side × side grid graph, 4-neighbour, every edge of weight `edge_weight` (a cluster shares
// ~10 welded edges with each neighbour).
ClusterAdjacency grid_graph(uint32_t side, uint32_t edge_weight) {
  ClusterAdjacency g;
  g.first.push_back(0);
  for (uint32_t y = 0; y < side; ++y)
    for (uint32_t x = 0; x < side; ++x) {
      const uint32_t c = y * side + x;
      // Neighbours ascending: up, left, right, down.
      if (y > 0) g.to.push_back(c - side);
      if (x > 0) g.to.push_back(c - 1);
      if (x + 1 < side) g.to.push_back(c + 1);
      if (y + 1 < side) g.to.push_back(c + side);
      g.weight.resize(g.to.size(), edge_weight);
      g.first.push_back(uint32_t(g.to.size()));
    }
  return g;
}

uint64_t cut_weight(const ClusterAdjacency& g, const std::vector<uint32_t>& part) {
  uint64_t cut = 0;
  for (size_t c = 0; c + 1 < g.first.size(); ++c)
    for (uint32_t e = g.first[c]; e < g.first[c + 1]; ++e)
      if (part[c] != part[g.to[e]]) cut += g.weight[e];
  return cut / 2;
}

TEST(ClusterPartition, GridGroupsAreNumberedByLowestNodeAndWithinTheWeightBounds) {
  const uint32_t side = 32, target = 16;
  const ClusterAdjacency g = grid_graph(side, 10);
  const size_t n = size_t(side) * side;
  std::vector<uint32_t> weight(n, 128);
  const size_t parts = (n + target - 1) / target;
  const std::vector<uint32_t> part = partition_clusters(g, weight, parts);
  ASSERT_EQ(part.size(), n);
  // Groups numbered in order of their lowest node: 0, 1, 2, ... as first seen.
  uint32_t next = 0;
  std::vector<uint64_t> group_weight;
  for (size_t c = 0; c < n; ++c) {
    ASSERT_LE(part[c], next);
    if (part[c] == next) {
      ++next;
      group_weight.push_back(0);
    }
    group_weight[part[c]] += weight[c];
  }
  // A connected graph of equal nodes: every group between half and twice the mean weight
  // (the small-group and merge caps), and about as many groups as asked.
  const double mean = double(n) * 128 / double(parts);
  for (uint64_t w : group_weight) {
    EXPECT_GE(double(w), 0.5 * mean);
    EXPECT_LE(double(w), 2.0 * mean);
  }
  EXPECT_GE(group_weight.size(), parts * 3 / 4);
  EXPECT_LE(group_weight.size(), parts * 5 / 4);
  // A tiling by 4 × 4 squares cuts 2 · 32 · 7 edges; greedy groups may be less regular but
  // not much longer in border.
  const uint64_t tiling_cut = 2ull * side * (side / 4 - 1) * 10;
  EXPECT_LE(cut_weight(g, part), tiling_cut * 3 / 2);
}

TEST(ClusterPartition, SameInputSameGroupsAndIsolatedNodesStayAlone) {
  // Two grids side by side with no edge between them plus two isolated nodes: the partition
  // is a pure function of the input, and no group spans two components (nothing links them).
  ClusterAdjacency a = grid_graph(12, 7);
  const uint32_t na = 144;
  ClusterAdjacency g = a;
  for (size_t c = 0; c < na; ++c) {
    for (uint32_t e = a.first[c]; e < a.first[c + 1]; ++e) {
      g.to.push_back(a.to[e] + na);
      g.weight.push_back(a.weight[e]);
    }
    g.first.push_back(uint32_t(g.to.size()));
  }
  g.first.push_back(uint32_t(g.to.size()));
  g.first.push_back(uint32_t(g.to.size()));
  const size_t n = 2 * na + 2;
  std::vector<uint32_t> weight(n);
  for (size_t c = 0; c < n; ++c) weight[c] = 100 + uint32_t(c % 29);  // uneven, as at coarse levels
  const std::vector<uint32_t> p1 = partition_clusters(g, weight, n / 16);
  const std::vector<uint32_t> p2 = partition_clusters(g, weight, n / 16);
  EXPECT_EQ(p1, p2);
  for (size_t c = 0; c < na; ++c)
    for (size_t d = na; d < 2 * na; ++d) ASSERT_NE(p1[c], p1[d]);
  EXPECT_NE(p1[n - 1], p1[n - 2]);
  for (size_t c = 0; c < n - 2; ++c) {
    EXPECT_NE(p1[c], p1[n - 1]);
    EXPECT_NE(p1[c], p1[n - 2]);
  }
}

}  // namespace
}  // namespace vgeo
