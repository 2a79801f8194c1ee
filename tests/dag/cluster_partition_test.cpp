// The greedy cluster partitioner (lib/vgeo/dag/cluster_partition.cpp, spec/dag.md §Grouping).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "vgeo/dag/build_internal.h"

namespace vgeo {
namespace {

using build_detail::ClusterAdjacency;
using build_detail::partition_clusters;

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
