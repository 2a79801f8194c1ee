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

#include "vgeo/dag/cluster_dag.h"

namespace vgeo::test {

inline constexpr float kLevel1Height = 0.02f, kLevel1Error = 0.03f;
inline constexpr float kLevel2Height = 0.05f, kLevel2Error = 0.06f;

struct HandDagShape {
  Vec3 offset{};       // added to every position
  float scale = 1.0f;  // grid spacing
  bool coarse_border = false;  // level 2 keeps only every other vertex of the mesh's open border
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

// Errors, shared values, bounds (bottom-up, spec/dag.md rules), BVH and DAG bounds.
inline void build_bvh(ClusterDag& dag, uint32_t node, uint32_t first, uint32_t count) {
  BvhNode nd;
  if (count <= kBvhMaxChildren) {
    nd.child_count = count;
    for (uint32_t i = 0; i < count; ++i) {
      nd.children[i] = first + i;
      nd.group_mask |= 1u << i;
      const DagGroup& G = dag.groups[first + i];
      nd.bounds = merge_spheres(nd.bounds, G.bounds);
      nd.lod_bounds = merge_spheres(nd.lod_bounds, G.parent_bounds);
      nd.max_parent_error = std::max(nd.max_parent_error, G.parent_error);
    }
    dag.bvh_nodes[node] = nd;
    return;
  }
  uint32_t per = (count + kBvhMaxChildren - 1) / kBvhMaxChildren;
  uint32_t children = (count + per - 1) / per;
  uint32_t base = uint32_t(dag.bvh_nodes.size());
  dag.bvh_nodes.resize(base + children);
  nd.child_count = children;
  for (uint32_t i = 0; i < children; ++i) {
    uint32_t f = first + i * per, n = std::min(per, first + count - f);
    build_bvh(dag, base + i, f, n);
    const BvhNode& c = dag.bvh_nodes[base + i];
    nd.children[i] = base + i;
    nd.bounds = merge_spheres(nd.bounds, c.bounds);
    nd.lod_bounds = merge_spheres(nd.lod_bounds, c.lod_bounds);
    nd.max_parent_error = std::max(nd.max_parent_error, c.max_parent_error);
  }
  dag.bvh_nodes[node] = nd;
}

inline void finish(ClusterDag& dag, const std::vector<float>& group_error) {
  for (uint32_t g = 0; g < dag.groups.size(); ++g) {
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
  dag.bvh_nodes.assign(1, BvhNode{});
  build_bvh(dag, 0, 0, uint32_t(dag.groups.size()));
  for (const DagCluster& k : dag.clusters)
    if (k.generating_group == kNone)
      for (uint32_t v = 0; v < k.vertex_count; ++v) dag.bounds.extend(dag.position(k.vertex_offset + v));
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
    const int step = shape.coarse_border ? 2 : 1;
    for (int half = 0; half < 2; ++half) {
      std::vector<std::array<Vec3, 3>> tris;
      for (int i = 16 * half; i < 16 * half + 16; i += step) {
        auto a = border[i], b = border[(i + step) % 32];
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

  const float e1 = kLevel1Error * shape.scale, e2 = kLevel2Error * shape.scale;
  hand_dag_detail::finish(dag, {e1, e1, e1, e1, e2, kTerminalError});
  return dag;
}

// The same construction at any size: a 2^k x 2^k-quad grid (k ≥ 2). Level-L groups cover
// squares of 4·2^L quads (level 0: 2x2 tiles of 2x2 quads); each generates a fan over its
// square's border (centre raised by quadtree_height(L + 1)) split into chunks of
// min(128, border / 2) triangles; the level-(k-2) group is terminal. Stored errors are 1.5x
// the fan heights, so measured/stored = 2/3 everywhere.
inline float quadtree_height(uint32_t level) { return 0.01f * float(1u << level); }

inline ClusterDag make_quadtree_dag(uint32_t k) {
  using namespace hand_dag_detail;
  const int side = 1 << k;
  const uint32_t top = k - 2;
  auto P = [](double x, double y, double z) { return Vec3{float(x), float(y), float(z)}; };
  ClusterDag dag;
  std::vector<uint32_t> base(top + 2, 0);
  for (uint32_t L = 0; L <= top; ++L) {
    uint32_t n = uint32_t(side / (4 << L));
    base[L + 1] = base[L] + n * n;
  }
  dag.groups.resize(base[top + 1]);
  std::vector<float> errors(dag.groups.size());
  // Level 0.
  {
    int n = side / 4;
    for (int by = 0; by < n; ++by)
      for (int bx = 0; bx < n; ++bx) {
        uint32_t g = base[0] + uint32_t(by * n + bx);
        dag.groups[g].first_cluster = uint32_t(dag.clusters.size());
        dag.groups[g].cluster_count = 4;
        for (int t = 0; t < 4; ++t) {
          int x0 = 4 * bx + 2 * (t % 2), y0 = 4 * by + 2 * (t / 2);
          std::vector<std::array<Vec3, 3>> tris;
          for (int y = y0; y < y0 + 2; ++y)
            for (int x = x0; x < x0 + 2; ++x) {
              Vec3 a = P(x, y, 0), b = P(x + 1, y, 0), c = P(x, y + 1, 0), d = P(x + 1, y + 1, 0);
              tris.push_back({a, b, d});
              tris.push_back({a, d, c});
            }
          add_cluster(dag, tris, g, kNone, 0);
        }
      }
  }
  for (uint32_t L = 0; L < top; ++L) {
    int n_up = side / (4 << (L + 1)), n = 2 * n_up, s = 4 << L;
    for (int by = 0; by < n_up; ++by)
      for (int bx = 0; bx < n_up; ++bx) {
        uint32_t up = base[L + 1] + uint32_t(by * n_up + bx);
        dag.groups[up].first_cluster = uint32_t(dag.clusters.size());
        dag.groups[up].level = L + 1;
        for (int c = 0; c < 4; ++c) {
          int cx = 2 * bx + c % 2, cy = 2 * by + c / 2;
          uint32_t child = base[L] + uint32_t(cy * n + cx);
          DagGroup& C = dag.groups[child];
          C.first_generated = uint32_t(dag.generated_clusters.size());
          auto border = perimeter(cx * s, cy * s, s);
          const int count = int(border.size()), chunk = std::min(128, count / 2);
          Vec3 centre = P(cx * s + s / 2, cy * s + s / 2, quadtree_height(L + 1));
          for (int first = 0; first < count; first += chunk) {
            std::vector<std::array<Vec3, 3>> tris;
            for (int i = first; i < std::min(count, first + chunk); ++i) {
              auto a = border[i], b = border[(i + 1) % count];
              tris.push_back({centre, P(a[0], a[1], 0), P(b[0], b[1], 0)});
            }
            dag.generated_clusters.push_back(add_cluster(dag, tris, up, child, L + 1));
          }
          dag.groups[child].generated_count = uint32_t(dag.generated_clusters.size()) - dag.groups[child].first_generated;
          errors[child] = 1.5f * quadtree_height(L + 1);
        }
        dag.groups[up].cluster_count = uint32_t(dag.clusters.size()) - dag.groups[up].first_cluster;
      }
  }
  dag.groups.back().flags = kGroupTerminal;
  errors.back() = kTerminalError;
  dag.level_count = top + 1;
  finish(dag, errors);
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
