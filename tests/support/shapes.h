#pragma once
// Tiny deterministic meshes for unit tests (the full generator is lib/vgeo/mesh/generate.h).
#include <cmath>
#include <cstdint>
#include <vector>

#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/mesh.h"

namespace vgeo::test {

// A generated mesh (lib/vgeo/mesh/generate.h) with the options tests vary.
inline Mesh generated_mesh(GenShape shape, uint64_t triangles, uint64_t seed = 1, unsigned threads = 1,
                           uint32_t islands = 0) {
  GenerateOptions o;
  o.shape = shape;
  o.target_triangles = triangles;
  o.seed = seed;
  o.threads = threads;
  o.islands = islands;
  return generate_mesh(o);
}

// n x n quads in the XY plane over [0,size]^2, two triangles each, CCW seen from +Z.
// With `hole`, quads whose centre is within size/4 of the middle are left out.
inline Mesh make_grid(uint32_t n, float size = 1.0f, bool hole = false, Vec3 offset = {}) {
  Mesh m;
  m.name = "grid";
  for (uint32_t y = 0; y <= n; ++y)
    for (uint32_t x = 0; x <= n; ++x) {
      m.positions.insert(m.positions.end(),
                         {offset.x + size * x / n, offset.y + size * y / n, offset.z});
      m.normals.insert(m.normals.end(), {0, 0, 1});
      m.uvs.insert(m.uvs.end(), {float(x) / n, float(y) / n});
    }
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      if (hole) {
        float cx = (x + 0.5f) / n - 0.5f, cy = (y + 0.5f) / n - 0.5f;
        if (std::sqrt(cx * cx + cy * cy) < 0.25f) continue;
      }
      uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  return m;
}

// Closed UV sphere (poles welded): lib/vgeo/mesh's generator.
inline Mesh make_sphere(uint32_t rings, uint32_t segments, float radius = 1.0f, Vec3 center = {}) {
  return make_uv_sphere(rings, segments, radius, center);
}

// The same surface cut in two sheets along a seam whose two sides are one float ulp apart
// (as CAD/PLY exports of parts that touch often are): triangles whose centroid has x > 0 get
// their own copies of the vertices they share with the others, each copy's coordinates moved
// one ulp towards +inf. Exactly, the seam is two open borders; on any position grid of the
// page format both sides weld into one edge chain (spec/dag.md §2.3 Seams).
inline Mesh make_ulp_seam(const Mesh& src) {
  Mesh m = src;
  m.name = src.name + "-ulp-seam";
  const size_t tris = src.indices.size() / 3;
  auto right = [&](size_t t) {
    float x = 0;
    for (int k = 0; k < 3; ++k) x += src.positions[3 * src.indices[3 * t + k]];
    return x > 0;
  };
  std::vector<uint8_t> used_left(src.vertex_count(), 0);
  for (size_t t = 0; t < tris; ++t)
    if (!right(t))
      for (int k = 0; k < 3; ++k) used_left[src.indices[3 * t + k]] = 1;
  std::vector<uint32_t> copy(src.vertex_count(), ~uint32_t(0));
  for (size_t t = 0; t < tris; ++t) {
    if (!right(t)) continue;
    for (int k = 0; k < 3; ++k) {
      uint32_t& v = m.indices[3 * t + k];
      if (!used_left[v]) continue;
      if (copy[v] == ~uint32_t(0)) {
        copy[v] = uint32_t(m.vertex_count());
        for (int a = 0; a < 3; ++a)
          m.positions.push_back(std::nextafter(src.positions[3 * v + a], INFINITY));
        if (!src.normals.empty())
          for (int a = 0; a < 3; ++a) m.normals.push_back(src.normals[3 * v + a]);
        if (!src.uvs.empty())
          for (int a = 0; a < 2; ++a) m.uvs.push_back(src.uvs[2 * v + a]);
      }
      v = copy[v];
    }
  }
  return m;
}

// The same surface as a per-corner mesh (every triangle owns its three vertices, as many
// PLY/STL/Blender exports are): flat face normals, and uvs from the source (or a planar
// projection) with each triangle's uvs shifted by its own offset, so uv seams are everywhere.
inline Mesh make_per_corner(const Mesh& src, bool uv_seams = true) {
  Mesh m;
  m.name = src.name + "-per-corner";
  for (size_t t = 0; t < src.triangle_count(); ++t) {
    Vec3 p[3];
    for (int k = 0; k < 3; ++k) p[k] = src.position(src.indices[3 * t + k]);
    Vec3 n = cross(p[1] - p[0], p[2] - p[0]);
    float len = length(n);
    n = len > 0 ? n * (1.0f / len) : Vec3{0, 0, 1};
    const float shift = uv_seams ? float(t % 7) : 0.0f;
    for (int k = 0; k < 3; ++k) {
      uint32_t v = src.indices[3 * t + k];
      m.positions.insert(m.positions.end(), {p[k].x, p[k].y, p[k].z});
      m.normals.insert(m.normals.end(), {n.x, n.y, n.z});
      float u = src.uvs.empty() ? p[k].x : src.uvs[2 * v], w = src.uvs.empty() ? p[k].y : src.uvs[2 * v + 1];
      m.uvs.insert(m.uvs.end(), {u + shift, w});
      m.indices.push_back(uint32_t(3 * t + k));
    }
  }
  m.materials = src.materials;
  return m;
}

// `src` plus, after every `every`-th triangle (a, b, c), degenerate triangles as messy exports
// carry them: a repeated-corner triangle (a, a, b), one with a repeated position on a fresh
// copy a' of a (a', a, c), and a repeated-corner triangle (c, b, c).
inline Mesh make_with_degenerates(const Mesh& src, uint32_t every = 5) {
  Mesh m = src;
  m.name = src.name + "-degenerates";
  m.indices.clear();
  m.materials.clear();
  for (size_t t = 0; t < src.triangle_count(); ++t) {
    const uint32_t a = src.indices[3 * t], b = src.indices[3 * t + 1], c = src.indices[3 * t + 2];
    m.indices.insert(m.indices.end(), &src.indices[3 * t], &src.indices[3 * t] + 3);
    if (!src.materials.empty()) m.materials.push_back(src.materials[t]);
    if (t % every != 0) continue;
    m.positions.insert(m.positions.end(), &src.positions[3 * a], &src.positions[3 * a] + 3);
    if (!src.normals.empty()) m.normals.insert(m.normals.end(), &src.normals[3 * a], &src.normals[3 * a] + 3);
    if (!src.uvs.empty()) m.uvs.insert(m.uvs.end(), &src.uvs[2 * a], &src.uvs[2 * a] + 2);
    const uint32_t a2 = uint32_t(m.positions.size() / 3 - 1);
    m.indices.insert(m.indices.end(), {a, a, b, a2, a, c, c, b, c});
    if (!src.materials.empty()) m.materials.insert(m.materials.end(), 3, src.materials[t]);
  }
  return m;
}

// The same surface with a collinear sliver hung on an edge after every `every`-th triangle:
// (a', b', m) with a', b' copies of the triangle's corners a, b and m the float midpoint of a
// and b, so edge a-b is used three times and a-m, m-b once (a fin, spec/dag.md §2.3).
inline Mesh make_with_fins(const Mesh& src, uint32_t every = 5) {
  Mesh m = src;
  m.name = src.name + "-fins";
  m.indices.clear();
  m.materials.clear();
  auto copy_vertex = [&](uint32_t v, const float* p) {
    m.positions.insert(m.positions.end(), p, p + 3);
    if (!src.normals.empty()) m.normals.insert(m.normals.end(), &src.normals[3 * v], &src.normals[3 * v] + 3);
    if (!src.uvs.empty()) m.uvs.insert(m.uvs.end(), &src.uvs[2 * v], &src.uvs[2 * v] + 2);
    return uint32_t(m.positions.size() / 3 - 1);
  };
  for (size_t t = 0; t < src.triangle_count(); ++t) {
    const uint32_t a = src.indices[3 * t], b = src.indices[3 * t + 1];
    m.indices.insert(m.indices.end(), &src.indices[3 * t], &src.indices[3 * t] + 3);
    if (!src.materials.empty()) m.materials.push_back(src.materials[t]);
    if (t % every != 0) continue;
    float mid[3];
    for (int k = 0; k < 3; ++k) mid[k] = 0.5f * (src.positions[3 * a + k] + src.positions[3 * b + k]);
    const uint32_t a2 = copy_vertex(a, &src.positions[3 * a]), b2 = copy_vertex(b, &src.positions[3 * b]);
    const uint32_t mv = copy_vertex(a, mid);
    m.indices.insert(m.indices.end(), {a2, b2, mv});
    if (!src.materials.empty()) m.materials.push_back(src.materials[t]);
  }
  return m;
}

}  // namespace vgeo::test
