#include "vgeo/render/procedural.h"

#include <cmath>

namespace vgeo {

namespace {
constexpr double kPi = 3.14159265358979323846;
// Smooth pseudo-noise in [-1, 1]: three sines at incommensurate angles.
double smooth_noise(double x, double y, double z) {
  return (std::sin(x * 1.0 + 0.3 * y) * std::cos(z * 1.3 - 0.5 * x) +
          0.5 * std::sin(2.1 * y + 1.7 * z + 0.4) + 0.25 * std::sin(4.3 * x - 3.1 * z + 1.1)) /
         1.75;
}
}  // namespace

Mesh make_displaced_sphere(uint32_t rings, uint32_t segments, float radius, float amplitude, float frequency) {
  Mesh m;
  m.name = "displaced_sphere";
  auto height = [&](double x, double y, double z) {
    return 1.0 + amplitude * smooth_noise(frequency * x, frequency * y, frequency * z);
  };
  auto add = [&](double th, double ph) {
    double x = std::sin(th) * std::cos(ph), y = std::cos(th), z = std::sin(th) * std::sin(ph);
    double h = height(x, y, z);
    m.positions.insert(m.positions.end(), {float(radius * h * x), float(radius * h * y), float(radius * h * z)});
    m.uvs.insert(m.uvs.end(), {float(ph / (2 * kPi)), float(th / kPi)});
  };
  add(0, 0);
  for (uint32_t r = 1; r < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) add(kPi * r / rings, 2 * kPi * s / segments);
  add(kPi, 0);
  uint32_t south = uint32_t(m.positions.size() / 3 - 1);
  auto ring = [&](uint32_t r, uint32_t s) { return 1 + (r - 1) * segments + (s % segments); };
  // Seen from outside with y up and phi running from +x towards +z, CCW order is (a, d, c).
  for (uint32_t s = 0; s < segments; ++s) m.indices.insert(m.indices.end(), {0, ring(1, s + 1), ring(1, s)});
  for (uint32_t r = 1; r + 1 < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) {
      uint32_t a = ring(r, s), b = ring(r, s + 1), c = ring(r + 1, s), d = ring(r + 1, s + 1);
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  for (uint32_t s = 0; s < segments; ++s) m.indices.insert(m.indices.end(), {south, ring(rings - 1, s), ring(rings - 1, s + 1)});
  // Smooth normals: area-weighted face normals accumulated per vertex.
  m.normals.assign(m.positions.size(), 0.0f);
  std::vector<double> acc(m.positions.size(), 0.0);
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    uint32_t i0 = m.indices[3 * t], i1 = m.indices[3 * t + 1], i2 = m.indices[3 * t + 2];
    Vec3 p0 = m.position(i0), p1 = m.position(i1), p2 = m.position(i2);
    Vec3 n = cross(p1 - p0, p2 - p0);
    for (uint32_t i : {i0, i1, i2})
      for (int k = 0; k < 3; ++k) acc[3 * i + k] += n[k];
  }
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    double l = std::sqrt(acc[3 * v] * acc[3 * v] + acc[3 * v + 1] * acc[3 * v + 1] + acc[3 * v + 2] * acc[3 * v + 2]);
    for (int k = 0; k < 3; ++k) m.normals[3 * v + k] = l > 0 ? float(acc[3 * v + k] / l) : 0.0f;
  }
  return m;
}

Mesh make_ground_grid(uint32_t n, float size, float amplitude, float frequency) {
  Mesh m;
  m.name = "ground_grid";
  auto h = [&](double u, double v) { return amplitude * smooth_noise(frequency * u * 2 * kPi, 0.37, frequency * v * 2 * kPi); };
  for (uint32_t z = 0; z <= n; ++z)
    for (uint32_t x = 0; x <= n; ++x) {
      double u = double(x) / n, v = double(z) / n;
      m.positions.insert(m.positions.end(), {float((u - 0.5) * size), float(h(u, v)), float((v - 0.5) * size)});
      // Normal from central differences of the height field.
      double e = 1.0 / n, dx = (h(u + e, v) - h(u - e, v)) / (2 * e * size), dz = (h(u, v + e) - h(u, v - e)) / (2 * e * size);
      double l = std::sqrt(dx * dx + 1 + dz * dz);
      m.normals.insert(m.normals.end(), {float(-dx / l), float(1 / l), float(-dz / l)});
      m.uvs.insert(m.uvs.end(), {float(u), float(v)});
    }
  for (uint32_t z = 0; z < n; ++z)
    for (uint32_t x = 0; x < n; ++x) {
      uint32_t a = z * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      // Seen from +y: x right, z towards the viewer → (a, c, d) is counter-clockwise.
      m.indices.insert(m.indices.end(), {a, c, d, a, d, b});
    }
  return m;
}

}  // namespace vgeo
