#pragma once
// Tiny deterministic meshes for unit tests (the full generator is lib/vgeo/mesh/generate.h).
#include <cmath>
#include <cstdint>

#include "vgeo/mesh/mesh.h"

namespace vgeo::test {

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

// Closed UV sphere (poles welded), `rings` x `segments`, CCW seen from outside.
inline Mesh make_sphere(uint32_t rings, uint32_t segments, float radius = 1.0f, Vec3 center = {}) {
  Mesh m;
  m.name = "sphere";
  const double pi = 3.14159265358979323846;
  auto add = [&](double th, double ph) {
    double x = std::sin(th) * std::cos(ph), y = std::sin(th) * std::sin(ph), z = std::cos(th);
    m.positions.insert(m.positions.end(), {center.x + float(radius * x), center.y + float(radius * y),
                                           center.z + float(radius * z)});
    m.normals.insert(m.normals.end(), {float(x), float(y), float(z)});
  };
  add(0, 0);  // north pole: vertex 0
  for (uint32_t r = 1; r < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) add(pi * r / rings, 2 * pi * s / segments);
  add(pi, 0);  // south pole
  uint32_t south = uint32_t(m.positions.size() / 3 - 1);
  auto ring = [&](uint32_t r, uint32_t s) { return 1 + (r - 1) * segments + (s % segments); };
  for (uint32_t s = 0; s < segments; ++s) m.indices.insert(m.indices.end(), {0, ring(1, s), ring(1, s + 1)});
  for (uint32_t r = 1; r + 1 < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) {
      uint32_t a = ring(r, s), b = ring(r, s + 1), c = ring(r + 1, s), d = ring(r + 1, s + 1);
      m.indices.insert(m.indices.end(), {a, c, d, a, d, b});
    }
  for (uint32_t s = 0; s < segments; ++s)
    m.indices.insert(m.indices.end(), {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
  return m;
}

}  // namespace vgeo::test
