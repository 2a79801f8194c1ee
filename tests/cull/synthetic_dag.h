#pragma once
// Synthetic cluster DAGs for culling tests: no triangles that matter, only the bounds and
// errors, built with the same rules as the real builder (spec/dag.md):
//   parent_bounds = merge of members' lod_bounds, parent_error = max(member lod_error) + own,
//   generated clusters share (lod_bounds, lod_error) = (group parent_bounds, parent_error),
//   and each generated cluster stands for a slice of the group's leaves (the leaf sets of a
//   group's generated clusters partition the union of its members' leaf sets).
// Small integer coordinates make coincident spheres and equal errors common.
#include <algorithm>
#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "vgeo/dag/cluster_dag.h"

namespace vgeo::test {

struct SyntheticDag {
  ClusterDag dag;
  std::vector<std::vector<uint32_t>> leaves;  // per cluster: the leaf clusters it replaces
  uint32_t leaf_count = 0;
};

inline SyntheticDag make_synthetic_dag(uint32_t seed, uint32_t leaf_count, uint32_t group_size,
                                       bool with_triangles = false) {
  std::mt19937 rng(seed);
  auto uni = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  SyntheticDag s;
  ClusterDag& d = s.dag;
  s.leaf_count = leaf_count;
  auto add_cluster = [&](Sphere bounds, Sphere lod_bounds, float lod_error, uint32_t level, uint32_t gen,
                         std::vector<uint32_t> leaves) {
    DagCluster c;
    c.bounds = bounds;
    c.lod_bounds = lod_bounds;
    c.lod_error = lod_error;
    c.level = level;
    c.generating_group = gen;
    c.vertex_offset = uint32_t(d.positions.size() / 3);
    c.triangle_offset = uint32_t(d.indices.size() / 3);
    c.material_offset = c.triangle_offset;
    // One triangle inside the sphere so raster/shade code paths can run.
    Vec3 o = bounds.center;
    float r = std::max(bounds.radius * 0.5f, 1e-3f);
    d.positions.insert(d.positions.end(), {o.x - r, o.y - r, o.z, o.x + r, o.y - r, o.z, o.x, o.y + r, o.z});
    d.indices.insert(d.indices.end(), {0, 1, 2});
    d.triangle_materials.push_back(0);
    c.vertex_count = 3;
    c.triangle_count = 1;
    d.clusters.push_back(c);
    s.leaves.push_back(std::move(leaves));
    return uint32_t(d.clusters.size() - 1);
  };
  (void)with_triangles;
  std::vector<uint32_t> level_clusters;
  for (uint32_t i = 0; i < leaf_count; ++i) {
    Sphere b;
    b.center = {float(uni(-8, 8)), float(uni(-8, 8)), float(uni(-8, 8))};
    b.radius = float(uni(1, 3));
    level_clusters.push_back(add_cluster(b, b, 0.0f, 0, kNone, {i}));
  }
  uint32_t level = 0;
  for (;;) {
    bool last = level_clusters.size() <= group_size || level >= 12;
    std::vector<uint32_t> next;
    for (size_t first = 0; first < level_clusters.size(); first += group_size) {
      size_t end = std::min(level_clusters.size(), first + group_size);
      DagGroup g;
      g.first_cluster = level_clusters[first];
      g.cluster_count = uint32_t(end - first);
      g.level = level;
      float max_child = 0;
      std::vector<uint32_t> leaves;
      for (size_t k = first; k < end; ++k) {
        const DagCluster& c = d.clusters[level_clusters[k]];
        g.bounds = merge_spheres(g.bounds, c.bounds);
        g.parent_bounds = merge_spheres(g.parent_bounds, c.lod_bounds);
        max_child = std::max(max_child, c.lod_error);
        leaves.insert(leaves.end(), s.leaves[level_clusters[k]].begin(), s.leaves[level_clusters[k]].end());
      }
      uint32_t gi = uint32_t(d.groups.size());
      bool terminal = last || uni(0, 9) == 0;  // some groups get stuck early
      if (terminal) {
        g.flags = kGroupTerminal;
        g.parent_error = kTerminalError;
      } else {
        // Own simplification error: small integers (ties common), sometimes zero.
        g.parent_error = max_child + float(uni(0, 4)) * 0.25f;
      }
      d.groups.push_back(g);
      for (size_t k = first; k < end; ++k) {
        DagCluster& c = d.clusters[level_clusters[k]];
        c.group = gi;
        c.parent_bounds = g.parent_bounds;
        c.parent_error = g.parent_error;
      }
      if (!terminal) {
        uint32_t gen = std::max<uint32_t>(1, g.cluster_count / 2);
        d.groups[gi].first_generated = uint32_t(d.generated_clusters.size());
        d.groups[gi].generated_count = gen;
        for (uint32_t k = 0; k < gen; ++k) {
          size_t a = leaves.size() * k / gen, b = leaves.size() * (k + 1) / gen;
          uint32_t ci = add_cluster(d.groups[gi].bounds, d.groups[gi].parent_bounds, d.groups[gi].parent_error,
                                    level + 1, gi, std::vector<uint32_t>(leaves.begin() + a, leaves.begin() + b));
          d.generated_clusters.push_back(ci);
          next.push_back(ci);
        }
      }
    }
    if (next.empty()) break;
    level_clusters = std::move(next);
    ++level;
  }
  d.level_count = level + 1;
  // BVH8 over all groups, in index order (any partition is valid; this one mixes levels).
  std::function<uint32_t(uint32_t, uint32_t)> make = [&](uint32_t lo, uint32_t hi) -> uint32_t {
    uint32_t ni = uint32_t(d.bvh_nodes.size());
    d.bvh_nodes.emplace_back();
    BvhNode node;
    uint32_t n = hi - lo;
    auto absorb = [&](const Sphere& b, const Sphere& lb, float e) {
      node.bounds = merge_spheres(node.bounds, b);
      node.lod_bounds = merge_spheres(node.lod_bounds, lb);
      node.max_parent_error = std::max(node.max_parent_error, e);
    };
    if (n <= kBvhMaxChildren) {
      for (uint32_t k = 0; k < n; ++k) {
        node.children[k] = lo + k;
        node.group_mask |= 1u << k;
        absorb(d.groups[lo + k].bounds, d.groups[lo + k].parent_bounds, d.groups[lo + k].parent_error);
      }
      node.child_count = n;
    } else {
      uint32_t step = (n + kBvhMaxChildren - 1) / kBvhMaxChildren, k = 0;
      for (uint32_t s0 = lo; s0 < hi; s0 += step, ++k) {
        uint32_t child = make(s0, std::min(hi, s0 + step));
        node.children[k] = child;
        absorb(d.bvh_nodes[child].bounds, d.bvh_nodes[child].lod_bounds, d.bvh_nodes[child].max_parent_error);
      }
      node.child_count = k;
    }
    d.bvh_nodes[ni] = node;
    return ni;
  };
  make(0, uint32_t(d.groups.size()));
  for (size_t v = 0; v < d.vertex_count(); ++v) d.bounds.extend(d.position(v));
  return s;
}

}  // namespace vgeo::test
