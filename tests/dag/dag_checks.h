#pragma once
// Independent checks of a built DAG used by the builder's tests (the full checker is
// lib/vgeo/verify; these re-derive the properties the builder promises, from the output only).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <set>
#include <vector>

#include "vgeo/dag/build.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/math.h"

namespace vgeo::test {

struct PosKey {
  uint32_t b[3];
  bool operator<(const PosKey& o) const { return std::memcmp(b, o.b, sizeof(b)) < 0; }
  bool operator==(const PosKey& o) const { return std::memcmp(b, o.b, sizeof(b)) == 0; }
};
inline PosKey pos_key(const float* p) {
  PosKey k;
  std::memcpy(k.b, p, 12);
  return k;
}
using WeldedEdge = std::pair<PosKey, PosKey>;
inline WeldedEdge welded_edge(PosKey a, PosKey b) { return a < b ? WeldedEdge{a, b} : WeldedEdge{b, a}; }

inline PosKey corner_key(const ClusterDag& d, uint32_t cluster, uint32_t tri, int k) {
  const DagCluster& c = d.clusters[cluster];
  uint32_t v = c.vertex_offset + d.indices[3 * size_t(c.triangle_offset + tri) + k];
  return pos_key(&d.positions[3 * size_t(v)]);
}

// Welded edges of a set of clusters with their use counts.
inline std::map<WeldedEdge, int> edge_counts(const ClusterDag& d, const std::vector<uint32_t>& clusters) {
  std::map<WeldedEdge, int> m;
  for (uint32_t c : clusters)
    for (uint32_t t = 0; t < d.clusters[c].triangle_count; ++t)
      for (int k = 0; k < 3; ++k) {
        PosKey a = corner_key(d, c, t, k), b = corner_key(d, c, t, (k + 1) % 3);
        if (!(a == b)) ++m[welded_edge(a, b)];
      }
  return m;
}

inline bool sphere_bits_equal(const Sphere& a, const Sphere& b) { return std::memcmp(&a, &b, sizeof(Sphere)) == 0; }

// Structural + error/bounds properties of the DAG (names = the properties).
inline void expect_dag_properties(const ClusterDag& d, size_t input_triangles) {
  ASSERT_FALSE(d.clusters.empty());
  ASSERT_FALSE(d.groups.empty());
  ASSERT_FALSE(d.bvh_nodes.empty());
  // cluster limits; no empty cluster; sorted by group; groups sorted by level
  size_t leaf_triangles = 0;
  for (size_t i = 0; i < d.clusters.size(); ++i) {
    const DagCluster& c = d.clusters[i];
    ASSERT_GE(c.triangle_count, 1u) << "cluster " << i << " has no triangles";
    ASSERT_LE(c.triangle_count, kMaxClusterTriangles);
    ASSERT_LE(c.vertex_count, kMaxClusterVertices);
    ASSERT_LT(c.group, d.groups.size());
    if (i > 0) {
      ASSERT_LE(d.clusters[i - 1].group, c.group) << "clusters sorted by group";
    }
    if (c.level == 0) {
      leaf_triangles += c.triangle_count;
      EXPECT_EQ(c.lod_error, 0.0f);
      EXPECT_EQ(c.generating_group, kNone);
      EXPECT_TRUE(sphere_bits_equal(c.lod_bounds, c.bounds));
    } else {
      ASSERT_LT(c.generating_group, d.groups.size());
      const DagGroup& g = d.groups[c.generating_group];
      EXPECT_EQ(c.lod_error, g.parent_error) << "lod_error == generating group's parent_error";
      EXPECT_TRUE(sphere_bits_equal(c.lod_bounds, g.parent_bounds));
      EXPECT_EQ(c.level, g.level + 1);
    }
    const DagGroup& mg = d.groups[c.group];
    EXPECT_EQ(c.parent_error, mg.parent_error) << "siblings share parent_error";
    EXPECT_TRUE(sphere_bits_equal(c.parent_bounds, mg.parent_bounds)) << "siblings share parent_bounds";
    EXPECT_GE(c.parent_error, c.lod_error) << "parent_error >= lod_error, cluster " << i;
    EXPECT_TRUE(sphere_contains(c.parent_bounds, c.lod_bounds)) << "parent_bounds encloses lod_bounds, cluster " << i;
    for (uint32_t t = 0; t < c.triangle_count; ++t)
      for (int k = 0; k < 3; ++k) ASSERT_LT(d.indices[3 * size_t(c.triangle_offset + t) + k], c.vertex_count);
    EXPECT_EQ(c.material_offset, c.triangle_offset);
  }
  EXPECT_EQ(leaf_triangles, input_triangles) << "every input triangle is in exactly one leaf";
  for (size_t g = 0; g < d.groups.size(); ++g) {
    const DagGroup& grp = d.groups[g];
    if (g > 0) {
      ASSERT_LE(d.groups[g - 1].level, grp.level) << "groups sorted by level";
    }
    ASSERT_GE(grp.cluster_count, 1u);
    bool terminal = grp.flags & kGroupTerminal;
    EXPECT_EQ(terminal, grp.generated_count == 0) << "terminal iff no generated clusters, group " << g;
    if (terminal) {
      EXPECT_EQ(grp.parent_error, kTerminalError);
    }
    for (uint32_t c = grp.first_cluster; c < grp.first_cluster + grp.cluster_count; ++c) {
      EXPECT_EQ(d.clusters[c].group, g);
      EXPECT_GE(grp.parent_error, d.clusters[c].lod_error);
      EXPECT_TRUE(sphere_contains(grp.parent_bounds, d.clusters[c].lod_bounds));
      EXPECT_TRUE(sphere_contains(grp.bounds, d.clusters[c].bounds));
    }
    for (uint32_t k = 0; k < grp.generated_count; ++k) {
      uint32_t c = d.generated_clusters[grp.first_generated + k];
      EXPECT_EQ(d.clusters[c].generating_group, g);
    }
  }
  // every cluster's own bounds enclose its vertices
  for (size_t i = 0; i < d.clusters.size(); ++i) {
    const DagCluster& c = d.clusters[i];
    for (uint32_t v = 0; v < c.vertex_count; ++v)
      EXPECT_TRUE(sphere_contains(c.bounds, Sphere{d.position(c.vertex_offset + v), 0.0f}));
  }
}

// Locked borders: for every non-terminal group, the welded edges its members share with
// clusters of other groups of the same level (and with retired clusters of lower
// levels) are all edges of its generated clusters. With `same_use_count`, each is also
// used as often as before (on a manifold: once, still a border); meshes whose welded
// surface is non-manifold (coincident vertices) may gain extra zero-area uses.
inline void expect_borders_preserved(const ClusterDag& d, bool same_use_count = true) {
  uint32_t levels = 0;
  for (const DagGroup& g : d.groups) levels = std::max(levels, g.level + 1);
  for (uint32_t level = 0; level < levels; ++level) {
    // owners of each welded edge among clusters that are members at this level or retired before
    std::map<WeldedEdge, std::set<uint32_t>> owners;  // edge -> groups (retired: group id too)
    for (size_t gi = 0; gi < d.groups.size(); ++gi) {
      const DagGroup& g = d.groups[gi];
      bool live = g.level == level || (g.level < level && (g.flags & kGroupTerminal));
      if (!live) continue;
      std::vector<uint32_t> members;
      for (uint32_t c = g.first_cluster; c < g.first_cluster + g.cluster_count; ++c) members.push_back(c);
      for (auto& [e, n] : edge_counts(d, members)) owners[e].insert(uint32_t(gi));
    }
    for (size_t gi = 0; gi < d.groups.size(); ++gi) {
      const DagGroup& g = d.groups[gi];
      if (g.level != level || (g.flags & kGroupTerminal)) continue;
      std::vector<uint32_t> members, generated;
      for (uint32_t c = g.first_cluster; c < g.first_cluster + g.cluster_count; ++c) members.push_back(c);
      for (uint32_t k = 0; k < g.generated_count; ++k) generated.push_back(d.generated_clusters[g.first_generated + k]);
      auto before = edge_counts(d, members);
      auto after = edge_counts(d, generated);
      for (auto& [e, n] : before) {
        if (owners[e].size() < 2) continue;  // not shared with another group
        auto it = after.find(e);
        ASSERT_TRUE(it != after.end()) << "group " << gi << " (level " << level << ") lost a locked border edge";
        if (same_use_count) {
          EXPECT_EQ(it->second, n) << "group " << gi << ": locked border edge use count changed";
        }
      }
    }
  }
}

}  // namespace vgeo::test
