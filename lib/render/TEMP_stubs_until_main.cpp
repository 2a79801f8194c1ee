// TEMPORARY (h/runtime only): stand-ins for rasterize_cluster, perspective_reversed_z and
// build_dag until the raster and build helpers land in main. Deleted at `git merge main`.
// build_dag here makes a single-level DAG: meshlets, one terminal group per <=8 clusters,
// a BVH8 over the groups.
#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "vgeo/build/build.h"
#include "vgeo/build/dag_io.h"
#include "vgeo/core/error.h"
#include "vgeo/raster/raster.h"

namespace vgeo {

Mat4d perspective_reversed_z(double fov_y_radians, double aspect, double z_near) {
  double f = 1.0 / std::tan(0.5 * fov_y_radians);
  Mat4d m;
  for (double& v : m.m) v = 0;
  m.at(0, 0) = f / aspect;
  m.at(1, 1) = f;
  m.at(2, 3) = z_near;
  m.at(3, 2) = -1;
  return m;
}

void rasterize_cluster(VisBuffer& target, const float* positions, uint32_t, const uint8_t* indices,
                       uint32_t triangle_count, const Mat4& m, uint32_t visible_cluster,
                       const RasterOptions& options, RasterStats* stats) {
  for (uint32_t t = 0; t < triangle_count; ++t) {
    double sx[3], sy[3], dz[3];
    bool ok = true;
    for (int k = 0; k < 3; ++k) {
      const float* p = positions + 3 * indices[3 * t + k];
      double c[4];
      for (int r = 0; r < 4; ++r) c[r] = m.at(r, 0) * p[0] + m.at(r, 1) * p[1] + m.at(r, 2) * p[2] + m.at(r, 3);
      if (!(c[3] >= options.z_near)) { ok = false; break; }
      sx[k] = (c[0] / c[3] * 0.5 + 0.5) * target.width;
      sy[k] = (0.5 - c[1] / c[3] * 0.5) * target.height;
      dz[k] = c[2] / c[3];
    }
    if (!ok) continue;
    double area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
    if (area == 0 || (options.cull_backfaces && area > 0)) continue;  // screen y down: CCW → area < 0
    int x0 = std::max(0, int(std::floor(std::min({sx[0], sx[1], sx[2]}))));
    int x1 = std::min(int(target.width) - 1, int(std::ceil(std::max({sx[0], sx[1], sx[2]}))));
    int y0 = std::max(0, int(std::floor(std::min({sy[0], sy[1], sy[2]}))));
    int y1 = std::min(int(target.height) - 1, int(std::ceil(std::max({sy[0], sy[1], sy[2]}))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        double px = x + 0.5, py = y + 0.5, w[3];
        for (int k = 0; k < 3; ++k) {
          int a = (k + 1) % 3, b = (k + 2) % 3;
          w[k] = ((sx[b] - sx[a]) * (py - sy[a]) - (sy[b] - sy[a]) * (px - sx[a])) / area;
        }
        if (w[0] < 0 || w[1] < 0 || w[2] < 0) continue;
        float d = float(w[0] * dz[0] + w[1] * dz[1] + w[2] * dz[2]);
        if (!(d > 0) || !std::isfinite(d)) continue;
        target.write_max(uint32_t(x), uint32_t(y), pack_vis_key(d, visible_cluster, t));
        if (stats) ++stats->pixels_written;
      }
  }
  if (stats) stats->triangles_in += triangle_count;
}

namespace {
Sphere sphere_of_points(const float* p, const uint32_t* idx, size_t n) {
  Aabb b;
  for (size_t i = 0; i < n; ++i) b.extend(Vec3{p[3 * idx[i]], p[3 * idx[i] + 1], p[3 * idx[i] + 2]});
  Sphere s;
  s.center = (b.min + b.max) * 0.5f;
  double r = 0;
  for (size_t i = 0; i < n; ++i) r = std::max(r, distance_d(s.center, Vec3{p[3 * idx[i]], p[3 * idx[i] + 1], p[3 * idx[i] + 2]}));
  s.radius = float(r * 1.0001) + 1e-30f;
  return s;
}
}  // namespace

ClusterDag build_dag(const Mesh& mesh, const BuildOptions&, BuildReport*) {
  if (mesh.triangle_count() == 0) fail("BUILD_EMPTY_MESH", mesh.name, "mesh has no triangles");
  ClusterDag dag;
  size_t max_meshlets = meshopt_buildMeshletsBound(mesh.indices.size(), 128, 128);
  std::vector<meshopt_Meshlet> meshlets(max_meshlets);
  std::vector<unsigned> mv(max_meshlets * 128);
  std::vector<unsigned char> mt(max_meshlets * 128 * 3);
  size_t count = meshopt_buildMeshlets(meshlets.data(), mv.data(), mt.data(), mesh.indices.data(), mesh.indices.size(),
                                       mesh.positions.data(), mesh.vertex_count(), 12, 128, 128, 0.0f);
  for (size_t i = 0; i < count; ++i) {
    const meshopt_Meshlet& ml = meshlets[i];
    DagCluster c;
    c.vertex_offset = uint32_t(dag.positions.size() / 3);
    c.vertex_count = ml.vertex_count;
    c.triangle_offset = uint32_t(dag.indices.size() / 3);
    c.triangle_count = ml.triangle_count;
    c.material_offset = c.triangle_offset;
    for (uint32_t v = 0; v < ml.vertex_count; ++v) {
      uint32_t g = mv[ml.vertex_offset + v];
      for (int k = 0; k < 3; ++k) dag.positions.push_back(mesh.positions[3 * g + k]);
      if (!mesh.normals.empty()) for (int k = 0; k < 3; ++k) dag.normals.push_back(mesh.normals[3 * g + k]);
      if (!mesh.uvs.empty()) for (int k = 0; k < 2; ++k) dag.uvs.push_back(mesh.uvs[2 * g + k]);
    }
    std::vector<uint32_t> gidx;
    for (uint32_t t = 0; t < ml.triangle_count * 3; ++t) {
      dag.indices.push_back(mt[ml.triangle_offset + t]);
      gidx.push_back(mv[ml.vertex_offset + mt[ml.triangle_offset + t]]);
    }
    for (uint32_t t = 0; t < ml.triangle_count; ++t) dag.triangle_materials.push_back(0);
    c.bounds = sphere_of_points(mesh.positions.data(), gidx.data(), gidx.size());
    c.lod_bounds = c.bounds;
    c.lod_error = 0;
    c.parent_error = kTerminalError;
    dag.clusters.push_back(c);
  }
  for (size_t t = 0; t < mesh.triangle_count() && !mesh.materials.empty(); ++t) (void)t;
  const uint32_t per_group = 8;
  for (uint32_t first = 0; first < dag.clusters.size(); first += per_group) {
    DagGroup g;
    g.first_cluster = first;
    g.cluster_count = std::min<uint32_t>(per_group, uint32_t(dag.clusters.size()) - first);
    g.flags = kGroupTerminal;
    g.parent_error = kTerminalError;
    for (uint32_t k = 0; k < g.cluster_count; ++k) g.bounds = merge_spheres(g.bounds, dag.clusters[first + k].bounds);
    g.parent_bounds = g.bounds;
    uint32_t gi = uint32_t(dag.groups.size());
    for (uint32_t k = 0; k < g.cluster_count; ++k) {
      dag.clusters[first + k].group = gi;
      dag.clusters[first + k].parent_bounds = g.parent_bounds;
    }
    dag.groups.push_back(g);
  }
  std::function<uint32_t(uint32_t, uint32_t)> make = [&](uint32_t lo, uint32_t hi) -> uint32_t {
    uint32_t ni = uint32_t(dag.bvh_nodes.size());
    dag.bvh_nodes.emplace_back();
    BvhNode node;
    uint32_t n = hi - lo;
    if (n <= kBvhMaxChildren) {
      for (uint32_t k = 0; k < n; ++k) {
        node.children[k] = lo + k;
        node.group_mask |= 1u << k;
        node.bounds = merge_spheres(node.bounds, dag.groups[lo + k].bounds);
        node.lod_bounds = merge_spheres(node.lod_bounds, dag.groups[lo + k].parent_bounds);
        node.max_parent_error = std::max(node.max_parent_error, dag.groups[lo + k].parent_error);
      }
      node.child_count = n;
    } else {
      uint32_t step = (n + kBvhMaxChildren - 1) / kBvhMaxChildren;
      uint32_t k = 0;
      for (uint32_t s = lo; s < hi; s += step, ++k) {
        uint32_t child = make(s, std::min(hi, s + step));
        node.children[k] = child;
        node.bounds = merge_spheres(node.bounds, dag.bvh_nodes[child].bounds);
        node.lod_bounds = merge_spheres(node.lod_bounds, dag.bvh_nodes[child].lod_bounds);
        node.max_parent_error = std::max(node.max_parent_error, dag.bvh_nodes[child].max_parent_error);
      }
      node.child_count = k;
    }
    dag.bvh_nodes[ni] = node;
    return ni;
  };
  if (!dag.groups.empty()) make(0, uint32_t(dag.groups.size()));
  dag.level_count = 1;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) dag.bounds.extend(mesh.position(v));
  return dag;
}

void write_dag_file(const std::string& path, const BuiltScene&) {
  fail("NOT_IMPLEMENTED", path, "dag files need the builder branch");
}
BuiltScene read_dag_file(const std::string& path) {
  fail("NOT_IMPLEMENTED", path, "dag files need the builder branch");
}

}  // namespace vgeo
