#pragma once
// Valid ClusterDags for the format tests, made without the real builder: leaf clusters
// from meshopt_buildMeshlets over tests/support shapes, groups of consecutive clusters,
// a BVH8 over the groups; optionally a second level built from a coarser copy of the
// shape so that groups generate clusters (structure only: the format does not check
// simplification semantics, lib/vgeo/verify does).
#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "support/errors.h"
#include "support/shapes.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/hash.h"
#include "vgeo/format/decode_hash.h"
#include "vgeo/format/format.h"

namespace vgeo::test {

inline Sphere sphere_of(const std::vector<float>& pos, size_t first, size_t count) {
  Aabb b;
  for (size_t v = first; v < first + count; ++v) b.extend(Vec3{pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]});
  Sphere s;
  s.center = (b.min + b.max) * 0.5f;
  float r = 0;
  for (size_t v = first; v < first + count; ++v)
    r = std::max(r, float(distance_d(s.center, {pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]})));
  s.radius = r * 1.0001f + 1e-6f;
  return s;
}

// Appends the meshlets of `mesh` as clusters of `level` (materials: 3 bands by triangle).
inline void append_meshlets(ClusterDag& dag, const Mesh& mesh, uint32_t level, uint32_t max_vertices = 128) {
  const size_t max_tris = kMaxClusterTriangles;
  size_t bound = meshopt_buildMeshletsBound(mesh.indices.size(), max_vertices, max_tris);
  std::vector<meshopt_Meshlet> ms(bound);
  std::vector<unsigned> mv(bound * max_vertices);
  std::vector<unsigned char> mt(bound * max_tris * 3);
  size_t n = meshopt_buildMeshlets(ms.data(), mv.data(), mt.data(), mesh.indices.data(), mesh.indices.size(),
                                   mesh.positions.data(), mesh.vertex_count(), 12, max_vertices, max_tris, 0.0f);
  for (size_t i = 0; i < n; ++i) {
    const meshopt_Meshlet& m = ms[i];
    DagCluster c;
    c.vertex_offset = uint32_t(dag.vertex_count());
    c.vertex_count = m.vertex_count;
    c.triangle_offset = c.material_offset = uint32_t(dag.triangle_count());
    c.triangle_count = m.triangle_count;
    c.level = level;
    for (size_t v = 0; v < m.vertex_count; ++v) {
      const unsigned src = mv[m.vertex_offset + v];
      for (int k = 0; k < 3; ++k) dag.positions.push_back(mesh.positions[3 * src + k]);
      if (!mesh.normals.empty())
        for (int k = 0; k < 3; ++k) dag.normals.push_back(mesh.normals[3 * src + k]);
      if (!mesh.uvs.empty())
        for (int k = 0; k < 2; ++k) dag.uvs.push_back(mesh.uvs[2 * src + k]);
    }
    for (size_t t = 0; t < m.triangle_count; ++t) {
      for (int k = 0; k < 3; ++k) dag.indices.push_back(mt[m.triangle_offset + 3 * t + k]);
      dag.triangle_materials.push_back(uint32_t((t / 50 + i) % 3));
    }
    c.bounds = c.lod_bounds = sphere_of(dag.positions, c.vertex_offset, c.vertex_count);
    dag.clusters.push_back(c);
  }
}

// Groups clusters [first, end) in runs of `group_size`; returns the first group id.
inline uint32_t group_clusters(ClusterDag& dag, uint32_t first, uint32_t group_size, bool terminal) {
  const uint32_t first_group = uint32_t(dag.groups.size());
  for (uint32_t c = first; c < dag.clusters.size(); c += group_size) {
    DagGroup g;
    g.first_cluster = c;
    g.cluster_count = std::min<uint32_t>(group_size, uint32_t(dag.clusters.size()) - c);
    g.level = dag.clusters[c].level;
    g.flags = terminal ? uint32_t(kGroupTerminal) : 0u;
    g.parent_error = terminal ? kTerminalError : 0.01f * (g.level + 1);
    for (uint32_t k = c; k < c + g.cluster_count; ++k) {
      g.bounds = merge_spheres(g.bounds, dag.clusters[k].bounds);
      g.parent_bounds = merge_spheres(g.parent_bounds, dag.clusters[k].lod_bounds);
    }
    for (uint32_t k = c; k < c + g.cluster_count; ++k) {
      dag.clusters[k].group = uint32_t(dag.groups.size());
      dag.clusters[k].parent_bounds = g.parent_bounds;
      dag.clusters[k].parent_error = g.parent_error;
    }
    dag.groups.push_back(g);
  }
  return first_group;
}

inline void build_bvh(ClusterDag& dag) {
  dag.bvh_nodes.clear();
  if (dag.groups.empty()) return;
  std::function<uint32_t(uint32_t, uint32_t, bool)> node = [&](uint32_t lo, uint32_t hi, bool is_root) {
    const uint32_t id = uint32_t(dag.bvh_nodes.size());
    dag.bvh_nodes.emplace_back();
    (void)is_root;
    BvhNode n;
    const uint32_t count = hi - lo;
    if (count <= kBvhMaxChildren) {
      for (uint32_t g = lo; g < hi; ++g) {
        n.children[n.child_count] = g;
        n.group_mask |= 1u << n.child_count++;
        n.bounds = merge_spheres(n.bounds, dag.groups[g].bounds);
        n.lod_bounds = merge_spheres(n.lod_bounds, dag.groups[g].parent_bounds);
        n.max_parent_error = std::max(n.max_parent_error, dag.groups[g].parent_error);
      }
    } else {
      const uint32_t per = (count + kBvhMaxChildren - 1) / kBvhMaxChildren;
      for (uint32_t s = lo; s < hi; s += per) {
        const uint32_t child = node(s, std::min(hi, s + per), false);
        n.children[n.child_count++] = child;
        n.bounds = merge_spheres(n.bounds, dag.bvh_nodes[child].bounds);
        n.lod_bounds = merge_spheres(n.lod_bounds, dag.bvh_nodes[child].lod_bounds);
        n.max_parent_error = std::max(n.max_parent_error, dag.bvh_nodes[child].max_parent_error);
      }
    }
    dag.bvh_nodes[id] = n;
    return id;
  };
  node(0, uint32_t(dag.groups.size()), true);
}

inline void finish_dag(ClusterDag& dag) {
  dag.bounds = Aabb{};
  for (const DagCluster& c : dag.clusters)
    if (c.level == 0)
      for (uint32_t v = c.vertex_offset; v < c.vertex_offset + c.vertex_count; ++v) dag.bounds.extend(dag.position(v));
  dag.level_count = 0;
  for (const DagCluster& c : dag.clusters) dag.level_count = std::max(dag.level_count, c.level + 1);
  build_bvh(dag);
}

// One level of leaf clusters, all groups terminal.
inline ClusterDag make_leaf_dag(const Mesh& mesh, uint32_t group_size = 8) {
  ClusterDag dag;
  append_meshlets(dag, mesh, 0);
  group_clusters(dag, 0, group_size, true);
  finish_dag(dag);
  return dag;
}

// Two levels: leaves of `fine`, grouped (non-terminal) and all generating the clusters of
// `coarse` (level 1, one terminal group per 8).
inline ClusterDag make_two_level_dag(const Mesh& fine, const Mesh& coarse) {
  ClusterDag dag;
  append_meshlets(dag, fine, 0);
  const uint32_t leaf_groups_first = group_clusters(dag, 0, 4, false);
  const uint32_t leaf_group_end = uint32_t(dag.groups.size());
  const uint32_t first_coarse = uint32_t(dag.clusters.size());
  append_meshlets(dag, coarse, 1);
  group_clusters(dag, first_coarse, 8, true);
  // Round-robin: each leaf group generates a share of the coarse clusters.
  const uint32_t coarse_count = uint32_t(dag.clusters.size()) - first_coarse;
  const uint32_t lg = leaf_group_end - leaf_groups_first;
  for (uint32_t g = leaf_groups_first; g < leaf_group_end; ++g) {
    DagGroup& grp = dag.groups[g];
    grp.first_generated = uint32_t(dag.generated_clusters.size());
    for (uint32_t c = first_coarse + (g - leaf_groups_first); c < first_coarse + coarse_count; c += lg) {
      dag.generated_clusters.push_back(c);
      dag.clusters[c].generating_group = g;
      dag.clusters[c].lod_bounds = grp.parent_bounds;
      dag.clusters[c].lod_error = grp.parent_error;
    }
    grp.generated_count = uint32_t(dag.generated_clusters.size()) - grp.first_generated;
  }
  finish_dag(dag);
  return dag;
}

inline BuiltScene scene_of(std::vector<ClusterDag> meshes) {
  BuiltScene s;
  s.meshes = std::move(meshes);
  s.materials = {Material{"red", {1, 0, 0, 1}}, Material{"green", {0, 1, 0, 1}}, Material{"blue", {0, 0, 1, 1}}};
  for (uint32_t m = 0; m < s.meshes.size(); ++m) {
    Instance in;
    in.mesh = m;
    in.transform[12] = float(m) * 3.0f;
    s.instances.push_back(in);
  }
  return s;
}

// Canonical decode hash (spec/format.md §Conformance): lib/vgeo/format/decode_hash.h.
inline uint64_t decoded_hash(const BuiltScene& s) { return decode_hash(s); }

}  // namespace vgeo::test
