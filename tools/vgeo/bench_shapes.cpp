#include "bench_shapes.h"

#include <algorithm>
#include <cmath>

#include "vgeo/mesh/generate.h"

namespace vgeo::bench {

const char* shape_name(Shape s) {
  switch (s) {
    case Shape::kSphere: return "sphere";
    case Shape::kTerrain: return "terrain";
    case Shape::kIslands: return "islands";
    case Shape::kThin: return "thin";
  }
  return "?";
}

Mesh make_shape(Shape shape, uint32_t triangles, uint64_t seed) {
  GenerateOptions o;
  switch (shape) {
    case Shape::kSphere: o.shape = GenShape::kSphere; break;
    case Shape::kTerrain: o.shape = GenShape::kTerrain; break;
    case Shape::kIslands: o.shape = GenShape::kIslands; break;
    case Shape::kThin: o.shape = GenShape::kThin; break;
  }
  o.target_triangles = triangles;
  o.seed = seed;
  o.threads = 0;
  return generate_mesh(o);
}

Mesh make_ellipsoid(uint32_t triangles, float thickness) {
  // lib/vgeo/mesh's UV sphere (segments = 2 * rings: ~4 rings^2 triangles) squashed along z.
  const uint32_t rings = std::max(3u, uint32_t(std::lround(std::sqrt(double(triangles) / 4.0))));
  Mesh m = make_uv_sphere(rings, 2 * rings);
  m.name = "ellipsoid";
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    m.positions[3 * v + 2] *= thickness;
    // Normal of an ellipsoid: gradient of the implicit function, from the sphere's normal.
    Vec3 n{m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2] / thickness};
    const float l = length(n);
    for (int k = 0; k < 3; ++k) m.normals[3 * v + size_t(k)] = n[k] / l;
  }
  return m;
}

Mesh add_degenerate_triangles(Mesh m, uint32_t every) {
  size_t tris = m.triangle_count();
  for (size_t t = 0; t < tris; t += every) {
    uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1];
    m.indices.insert(m.indices.end(), {a, b, b});  // zero area: repeated corner
    // Collinear sliver on fresh duplicated vertices: a, midpoint(a, b), b.
    Vec3 pa = m.position(a), pb = m.position(b);
    Vec3 mid = (pa + pb) * 0.5f;
    uint32_t base = uint32_t(m.vertex_count());
    for (Vec3 p : {pa, mid, pb}) {
      m.positions.insert(m.positions.end(), {p.x, p.y, p.z});
      if (!m.normals.empty()) m.normals.insert(m.normals.end(), {0, 0, 1});
      if (!m.uvs.empty()) m.uvs.insert(m.uvs.end(), {0, 0});
    }
    m.indices.insert(m.indices.end(), {base, base + 1, base + 2});
    if (!m.materials.empty()) m.materials.insert(m.materials.end(), {0, 0});
  }
  return m;
}

BoxFrame box_frame(const Mesh& mesh) {
  Aabb b;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) b.extend(mesh.position(v));
  BoxFrame f;
  if (b.empty()) return f;
  f.center = (b.min + b.max) * 0.5f;
  f.half = (b.max - b.min) * 0.5f;
  return f;
}

}  // namespace vgeo::bench
