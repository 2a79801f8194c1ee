#pragma once
// A small, valid, hand-built 3-level cluster DAG over an 8x8-quad grid, for testing the
// checkers independently of the builder.
//
//  level 0: 16 leaf clusters (2x2-quad tiles, 8 triangles each) in 4 groups (quadrants).
//  level 1: each quadrant group generated 2 clusters: a fan of 16 triangles from the
//           quadrant's centre (raised by kLevel1Height) to its 16 border vertices, split 8/8.
//  level 2: one group of the 8 level-1 clusters generated 2 clusters: a fan of 32 triangles
//           from the square's centre (raised by kLevel2Height) to the 32 border vertices.
//           Their group is terminal.
// Border vertices are the leaves' own vertices, so every cut is crack-free; the raised
// centres give each level a measurable error below its stored lod_error.
#include <array>
#include <cmath>
#include <vector>

#include "vgeo/build/cluster_dag.h"

namespace vgeo::test {

inline constexpr float kLevel1Height = 0.02f, kLevel1Error = 0.03f;
inline constexpr float kLevel2Height = 0.05f, kLevel2Error = 0.06f;

struct HandDagShape {
  Vec3 offset{};       // added to every position
  float scale = 1.0f;  // grid spacing
};

namespace hand_dag_detail {

inline Sphere sphere_of(const std::vector<Vec3>& pts) {
  Aabb box;
  for (Vec3 p : pts) box.extend(p);
  Sphere s;
  s.center = (box.min + box.max) * 0.5f;
  double r = 0;
  for (Vec3 p : pts) r = std::max(r, distance_d(s.center, p));
  s.radius = float(r * (1.0 + kSphereRelativeSlack)) + std::numeric_limits<float>::min();
  return s;
}

// Appends a cluster made of triangles given by positions (welded within the cluster).
inline uint32_t add_cluster(ClusterDag& dag, const std::vector<std::array<Vec3, 3>>& tris, uint32_t group,
                            uint32_t generating_group, uint32_t level) {
  DagCluster k;
  k.vertex_offset = uint32_t(dag.vertex_count());
  k.triangle_offset = uint32_t(dag.triangle_count());
  k.material_offset = k.triangle_offset;
  k.group = group;
  k.generating_group = generating_group;
  k.level = level;
  std::vector<Vec3> verts;
  for (const auto& t : tris) {
    for (const Vec3& p : t) {
      uint32_t found = uint32_t(verts.size());
      for (uint32_t i = 0; i < verts.size(); ++i)
        if (verts[i].x == p.x && verts[i].y == p.y && verts[i].z == p.z) found = i;
      if (found == verts.size()) verts.push_back(p);
      dag.indices.push_back(uint8_t(found));
    }
    dag.triangle_materials.push_back(0);
  }
  for (Vec3 p : verts) {
    dag.positions.insert(dag.positions.end(), {p.x, p.y, p.z});
    dag.normals.insert(dag.normals.end(), {0, 0, 1});
  }
  k.vertex_count = uint32_t(verts.size());
  k.triangle_count = uint32_t(tris.size());
  k.bounds = sphere_of(verts);
  dag.clusters.push_back(k);
  return uint32_t(dag.clusters.size() - 1);
}

// Border vertices of the square [x0, x0+n] x [y0, y0+n] (grid units), counter-clockwise.
inline std::vector<std::array<int, 2>> perimeter(int x0, int y0, int n) {
  std::vector<std::array<int, 2>> p;
  for (int i = 0; i < n; ++i) p.push_back({x0 + i, y0});
  for (int i = 0; i < n; ++i) p.push_back({x0 + n, y0 + i});
  for (int i = 0; i < n; ++i) p.push_back({x0 + n - i, y0 + n});
  for (int i = 0; i < n; ++i) p.push_back({x0, y0 + n - i});
  return p;
}

}  // namespace hand_dag_detail

inline ClusterDag make_hand_dag(const HandDagShape& shape = {}) {
  using namespace hand_dag_detail;
  auto P = [&](double x, double y, double z) {
    return Vec3{float(shape.offset.x + shape.scale * x), float(shape.offset.y + shape.scale * y),
                float(shape.offset.z + shape.scale * z)};
  };
  ClusterDag dag;
  dag.groups.resize(6);
  // Level 0: quadrant q = (qx, qy) holds tiles (2qx + i, 2qy + j); group q.
  for (int q = 0; q < 4; ++q) {
    int qx = q % 2, qy = q / 2;
    dag.groups[q].first_cluster = uint32_t(dag.clusters.size());
    for (int t = 0; t < 4; ++t) {
      int tx = 2 * qx + t % 2, ty = 2 * qy + t / 2;
      std::vector<std::array<Vec3, 3>> tris;
      for (int y = 2 * ty; y < 2 * ty + 2; ++y)
        for (int x = 2 * tx; x < 2 * tx + 2; ++x) {
          Vec3 a = P(x, y, 0), b = P(x + 1, y, 0), c = P(x, y + 1, 0), d = P(x + 1, y + 1, 0);
          tris.push_back({a, b, d});
          tris.push_back({a, d, c});
        }
      add_cluster(dag, tris, uint32_t(q), kNone, 0);
    }
    dag.groups[q].cluster_count = 4;
    dag.groups[q].level = 0;
  }
  // Level 1: fans per quadrant, group 4.
  dag.groups[4].first_cluster = uint32_t(dag.clusters.size());
  for (int q = 0; q < 4; ++q) {
    int qx = q % 2, qy = q / 2;
    auto border = perimeter(4 * qx, 4 * qy, 4);
    Vec3 centre = P(4 * qx + 2, 4 * qy + 2, kLevel1Height);
    dag.groups[q].first_generated = uint32_t(dag.generated_clusters.size());
    for (int half = 0; half < 2; ++half) {
      std::vector<std::array<Vec3, 3>> tris;
      for (int i = 8 * half; i < 8 * half + 8; ++i) {
        auto a = border[i], b = border[(i + 1) % 16];
        tris.push_back({centre, P(a[0], a[1], 0), P(b[0], b[1], 0)});
      }
      dag.generated_clusters.push_back(add_cluster(dag, tris, 4, uint32_t(q), 1));
    }
    dag.groups[q].generated_count = 2;
  }
  dag.groups[4].cluster_count = 8;
  dag.groups[4].level = 1;
  // Level 2: one fan over the whole square, group 5 (terminal).
  dag.groups[5].first_cluster = uint32_t(dag.clusters.size());
  dag.groups[4].first_generated = uint32_t(dag.generated_clusters.size());
  {
    auto border = perimeter(0, 0, 8);
    Vec3 centre = P(4, 4, kLevel2Height);
    for (int half = 0; half < 2; ++half) {
      std::vector<std::array<Vec3, 3>> tris;
      for (int i = 16 * half; i < 16 * half + 16; ++i) {
        auto a = border[i], b = border[(i + 1) % 32];
        tris.push_back({centre, P(a[0], a[1], 0), P(b[0], b[1], 0)});
      }
      dag.generated_clusters.push_back(add_cluster(dag, tris, 5, 4, 2));
    }
  }
  dag.groups[4].generated_count = 2;
  dag.groups[5].cluster_count = 2;
  dag.groups[5].level = 2;
  dag.groups[5].flags = kGroupTerminal;
  dag.level_count = 3;

  // Errors and bounds, bottom-up (spec/dag.md rules).
  const float group_error[6] = {kLevel1Error * shape.scale, kLevel1Error * shape.scale, kLevel1Error * shape.scale,
                                kLevel1Error * shape.scale, kLevel2Error * shape.scale, kTerminalError};
  for (uint32_t g = 0; g < 6; ++g) {
    DagGroup& G = dag.groups[g];
    G.parent_error = group_error[g];
    for (uint32_t i = 0; i < G.cluster_count; ++i) {
      DagCluster& k = dag.clusters[G.first_cluster + i];
      if (k.generating_group == kNone) {
        k.lod_bounds = k.bounds;
        k.lod_error = 0;
      }
      G.bounds = merge_spheres(G.bounds, k.bounds);
      G.parent_bounds = merge_spheres(G.parent_bounds, k.lod_bounds);
    }
    for (uint32_t i = 0; i < G.cluster_count; ++i) {
      DagCluster& k = dag.clusters[G.first_cluster + i];
      k.parent_bounds = G.parent_bounds;
      k.parent_error = G.parent_error;
    }
    for (uint32_t i = 0; i < G.generated_count; ++i) {
      DagCluster& p = dag.clusters[dag.generated_clusters[G.first_generated + i]];
      p.lod_bounds = G.parent_bounds;
      p.lod_error = G.parent_error;
    }
  }
  BvhNode root;
  root.child_count = 6;
  root.group_mask = 0x3F;
  for (uint32_t g = 0; g < 6; ++g) {
    root.children[g] = g;
    root.bounds = merge_spheres(root.bounds, dag.groups[g].bounds);
    root.lod_bounds = merge_spheres(root.lod_bounds, dag.groups[g].parent_bounds);
    root.max_parent_error = std::max(root.max_parent_error, dag.groups[g].parent_error);
  }
  dag.bvh_nodes.push_back(root);
  for (const DagCluster& k : dag.clusters)
    if (k.generating_group == kNone)
      for (uint32_t v = 0; v < k.vertex_count; ++v) dag.bounds.extend(dag.position(k.vertex_offset + v));
  return dag;
}

// Writes a changed parent error of group g to every copy (members, generated clusters).
inline void set_group_parent_error(ClusterDag& dag, uint32_t g, float error) {
  DagGroup& G = dag.groups[g];
  G.parent_error = error;
  for (uint32_t i = 0; i < G.cluster_count; ++i) dag.clusters[G.first_cluster + i].parent_error = error;
  for (uint32_t i = 0; i < G.generated_count; ++i)
    dag.clusters[dag.generated_clusters[G.first_generated + i]].lod_error = error;
}
inline void set_group_parent_bounds(ClusterDag& dag, uint32_t g, Sphere s) {
  DagGroup& G = dag.groups[g];
  G.parent_bounds = s;
  for (uint32_t i = 0; i < G.cluster_count; ++i) dag.clusters[G.first_cluster + i].parent_bounds = s;
  for (uint32_t i = 0; i < G.generated_count; ++i)
    dag.clusters[dag.generated_clusters[G.first_generated + i]].lod_bounds = s;
}

}  // namespace vgeo::test
