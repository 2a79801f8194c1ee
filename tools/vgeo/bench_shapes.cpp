#include "bench_shapes.h"

#include <algorithm>
#include <cmath>

#include "vgeo/mesh/generate.h"

namespace vgeo::bench {
namespace {

constexpr double kPi = 3.14159265358979323846;

void append_sphere(Mesh& m, uint32_t triangles, Vec3 center, Vec3 radii) {
  // A UV sphere with segments = 2 * rings has ~4 rings^2 triangles.
  uint32_t rings = std::max(3u, uint32_t(std::lround(std::sqrt(double(triangles) / 4.0))));
  uint32_t segments = 2 * rings;
  uint32_t base = uint32_t(m.vertex_count());
  auto add = [&](double th, double ph) {
    double x = std::sin(th) * std::cos(ph), y = std::sin(th) * std::sin(ph), z = std::cos(th);
    m.positions.insert(m.positions.end(), {center.x + float(radii.x * x), center.y + float(radii.y * y),
                                           center.z + float(radii.z * z)});
    // Normal of an ellipsoid: gradient of the implicit function.
    Vec3 n{float(x / radii.x), float(y / radii.y), float(z / radii.z)};
    float l = length(n);
    m.normals.insert(m.normals.end(), {n.x / l, n.y / l, n.z / l});
    m.uvs.insert(m.uvs.end(), {float(ph / (2 * kPi)), float(th / kPi)});
  };
  add(0, 0);
  for (uint32_t r = 1; r < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) add(kPi * r / rings, 2 * kPi * s / segments);
  add(kPi, 0);
  uint32_t south = uint32_t(m.vertex_count() - 1);
  auto ring = [&](uint32_t r, uint32_t s) { return base + 1 + (r - 1) * segments + (s % segments); };
  for (uint32_t s = 0; s < segments; ++s) m.indices.insert(m.indices.end(), {base, ring(1, s), ring(1, s + 1)});
  for (uint32_t r = 1; r + 1 < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) {
      uint32_t a = ring(r, s), b = ring(r, s + 1), c = ring(r + 1, s), d = ring(r + 1, s + 1);
      m.indices.insert(m.indices.end(), {a, c, d, a, d, b});
    }
  for (uint32_t s = 0; s < segments; ++s)
    m.indices.insert(m.indices.end(), {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
}

}  // namespace

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
  Mesh m;
  m.name = "ellipsoid";
  append_sphere(m, triangles, {}, {1, 1, thickness});
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
