#pragma once
// Small value types shared by every stage. Plain structs, GPU-uploadable (std430-friendly
// where noted): no virtuals, no pointers.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace vgeo {

struct Vec3 {
  float x = 0, y = 0, z = 0;
  float& operator[](int i) { return (&x)[i]; }
  float operator[](int i) const { return (&x)[i]; }
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(Vec3 a) { return std::sqrt(dot(a, a)); }

// Morton code of three 10-bit cell coordinates (x in the lowest bit of each triple): the
// one spatial sort key of the builder's chunking and grouping and of the page container.
inline uint32_t morton_code(uint32_t x, uint32_t y, uint32_t z) {
  auto spread = [](uint32_t v) {  // 10 bits -> every third bit
    v &= 0x3FFu;
    v = (v | (v << 16)) & 0x030000FFu;
    v = (v | (v << 8)) & 0x0300F00Fu;
    v = (v | (v << 4)) & 0x030C30C3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
  };
  return spread(x) | (spread(y) << 1) | (spread(z) << 2);
}

// Distances in double: positions may sit 1e7 units from the origin (spec/invariants.md).
inline double distance_d(Vec3 a, Vec3 b) {
  double dx = double(a.x) - b.x, dy = double(a.y) - b.y, dz = double(a.z) - b.z;
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// 16 bytes: center + radius. A radius < 0 marks an empty sphere.
struct Sphere {
  Vec3 center;
  float radius = -1.0f;
};

struct Aabb {
  Vec3 min{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
           std::numeric_limits<float>::max()};
  Vec3 max{-std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
           -std::numeric_limits<float>::max()};
  bool empty() const { return min.x > max.x; }
  void extend(Vec3 p) {
    min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
    max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
  }
  void extend(const Aabb& b) {
    if (b.empty()) return;
    extend(b.min);
    extend(b.max);
  }
};

// Relative + absolute slack added to every merged sphere radius so that containment
// (child ⊆ parent) survives float rounding of the centre and radius. 2^-20 relative is
// far above float rounding of a sum of a few terms, far below any visible LOD change.
inline constexpr float kSphereRelativeSlack = 1.0f / (1 << 20);

// Smallest-ish sphere enclosing two spheres, computed in double, then rounded outward.
inline Sphere merge_spheres(const Sphere& a, const Sphere& b) {
  if (a.radius < 0) return b;
  if (b.radius < 0) return a;
  double d = distance_d(a.center, b.center);
  if (d + b.radius <= a.radius) return a;
  if (d + a.radius <= b.radius) return b;
  double r = 0.5 * (d + a.radius + b.radius);
  double t = d > 0 ? (r - a.radius) / d : 0.0;
  Sphere s;
  s.center = {float(a.center.x + (double(b.center.x) - a.center.x) * t),
              float(a.center.y + (double(b.center.y) - a.center.y) * t),
              float(a.center.z + (double(b.center.z) - a.center.z) * t)};
  // Re-measure against the rounded centre so both inputs are enclosed exactly.
  double ra = distance_d(s.center, a.center) + a.radius;
  double rb = distance_d(s.center, b.center) + b.radius;
  double rr = std::max(ra, rb);
  s.radius = float(rr * (1.0 + kSphereRelativeSlack)) + std::numeric_limits<float>::min();
  return s;
}

// True when `outer` encloses `inner` up to a relative tolerance `rel` of outer's radius.
inline bool sphere_contains(const Sphere& outer, const Sphere& inner, double rel = 0.0) {
  if (inner.radius < 0) return true;
  if (outer.radius < 0) return false;
  return distance_d(outer.center, inner.center) + inner.radius <=
         double(outer.radius) * (1.0 + rel);
}

// Column-major 4x4 matrix (glTF/GLSL convention): m[col * 4 + row].
struct Mat4 {
  float m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  float& at(int row, int col) { return m[col * 4 + row]; }
  float at(int row, int col) const { return m[col * 4 + row]; }
};

// Same in double, for composing camera and far-away instance transforms without
// losing the small offsets (instances 1e7 units away; spec/invariants.md).
struct Mat4d {
  double m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double& at(int row, int col) { return m[col * 4 + row]; }
  double at(int row, int col) const { return m[col * 4 + row]; }
};

inline Mat4d operator*(const Mat4d& a, const Mat4d& b) {
  Mat4d r;
  for (int c = 0; c < 4; ++c)
    for (int rr = 0; rr < 4; ++rr) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a.at(rr, k) * b.at(k, c);
      r.at(rr, c) = s;
    }
  return r;
}
inline Mat4 to_float(const Mat4d& a) {
  Mat4 r;
  for (int i = 0; i < 16; ++i) r.m[i] = float(a.m[i]);
  return r;
}
inline Mat4d to_double(const Mat4& a) {
  Mat4d r;
  for (int i = 0; i < 16; ++i) r.m[i] = a.m[i];
  return r;
}

}  // namespace vgeo
