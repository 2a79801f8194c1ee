#include "bench_shapes.h"

#include <algorithm>
#include <cmath>

namespace vgeo::bench {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Islands: how many disjoint pieces (enough that partitioning must group unconnected parts).
constexpr uint32_t kIslandCount = 12;
// Thin: the flattened ellipsoid's thickness relative to its width (a sliver-like shell).
constexpr float kThinRatio = 0.01f;

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

void make_terrain(Mesh& m, uint32_t triangles, Rng& rng) {
  uint32_t n = std::max(2u, uint32_t(std::lround(std::sqrt(double(triangles) / 2.0))));
  // A few octaves of sines with random phases and directions: smooth hills, no data files.
  constexpr int kOctaves = 5;
  double fx[kOctaves], fy[kOctaves], ph[kOctaves], amp[kOctaves];
  for (int o = 0; o < kOctaves; ++o) {
    double freq = 2.0 * std::pow(2.0, o), ang = rng.uniform(0, 2 * kPi);
    fx[o] = freq * std::cos(ang);
    fy[o] = freq * std::sin(ang);
    ph[o] = rng.uniform(0, 2 * kPi);
    amp[o] = 0.12 / std::pow(2.0, o);
  }
  auto height = [&](double x, double y) {
    double h = 0;
    for (int o = 0; o < kOctaves; ++o) h += amp[o] * std::sin(fx[o] * x + fy[o] * y + ph[o]);
    return h;
  };
  const double half = 0.7;  // the square fits in the unit ball
  for (uint32_t j = 0; j <= n; ++j)
    for (uint32_t i = 0; i <= n; ++i) {
      double x = -half + 2 * half * i / n, y = -half + 2 * half * j / n, e = 1e-4;
      double h = height(x, y);
      double dx = (height(x + e, y) - height(x - e, y)) / (2 * e), dy = (height(x, y + e) - height(x, y - e)) / (2 * e);
      double l = std::sqrt(dx * dx + dy * dy + 1);
      m.positions.insert(m.positions.end(), {float(x), float(y), float(h)});
      m.normals.insert(m.normals.end(), {float(-dx / l), float(-dy / l), float(1 / l)});
      m.uvs.insert(m.uvs.end(), {float(i) / n, float(j) / n});
    }
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
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
  Mesh m;
  m.name = shape_name(shape);
  Rng rng(seed);
  switch (shape) {
    case Shape::kSphere: append_sphere(m, triangles, {}, {1, 1, 1}); break;
    case Shape::kTerrain: make_terrain(m, triangles, rng); break;
    case Shape::kIslands:
      for (uint32_t k = 0; k < kIslandCount; ++k) {
        float r = float(rng.uniform(0.08, 0.2));
        double th = std::acos(rng.uniform(-1, 1)), ph = rng.uniform(0, 2 * kPi), d = rng.uniform(0.1, 1.0 - r);
        Vec3 c{float(d * std::sin(th) * std::cos(ph)), float(d * std::sin(th) * std::sin(ph)), float(d * std::cos(th))};
        append_sphere(m, std::max(8u, triangles / kIslandCount), c, {r, r, r});
      }
      break;
    case Shape::kThin: append_sphere(m, triangles, {}, {1, 1, kThinRatio}); break;
  }
  return m;
}

}  // namespace vgeo::bench
