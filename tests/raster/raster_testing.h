#pragma once
// Shared helpers for the rasterizer tests: pixel-space matrices, triangle generators that
// make degenerate, sliver, sub-pixel, huge and grid-snapped triangles common, and buffer
// comparison with a readable first mismatch.
#include <rapidcheck.h>

#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "vgeo/core/math.h"
#include "vgeo/raster/raster.h"

namespace vgeo::raster_test {

// Maps pixel coordinates (x right, y down, row 0 at the top) and depth z to clip space
// with w = 1: x_ndc = 2x/W − 1, y_ndc = 1 − 2y/H, depth = z. For power-of-two W and H and
// coordinates on the 1/256 grid the mapping to sub-pixel units is exact.
inline Mat4 pixel_to_clip(uint32_t width, uint32_t height) {
  Mat4 m;
  m.at(0, 0) = 2.0f / float(width);
  m.at(0, 3) = -1.0f;
  m.at(1, 1) = -2.0f / float(height);
  m.at(1, 3) = 1.0f;
  return m;
}

struct Tri {
  Vec3 v[3];
};

inline std::string describe(const Tri& t) {
  std::ostringstream s;
  s.precision(9);
  for (int i = 0; i < 3; ++i) s << "(" << t.v[i].x << ", " << t.v[i].y << ", " << t.v[i].z << ") ";
  return s.str();
}

// Rasterizes `tris` as one cluster (triangle i gets triangle index i).
inline RasterStats raster_tris(VisBuffer& buf, const std::vector<Tri>& tris, const Mat4& m,
                               uint32_t cluster, RasterOptions opt) {
  // Unshared vertices: 3 per triangle must fit the 8-bit local indices.
  RC_ASSERT(tris.size() * 3 <= kMaxClusterVertices);
  std::vector<float> pos;
  std::vector<uint8_t> idx;
  for (size_t i = 0; i < tris.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      pos.insert(pos.end(), {tris[i].v[k].x, tris[i].v[k].y, tris[i].v[k].z});
      idx.push_back(uint8_t(3 * i + k));
    }
  RasterStats stats;
  rasterize_cluster(buf, pos.data(), uint32_t(tris.size() * 3), idx.data(), uint32_t(tris.size()), m,
                    cluster, opt, &stats);
  return stats;
}

// Index of the first differing key, or -1.
inline long first_mismatch(const VisBuffer& a, const VisBuffer& b) {
  if (a.width != b.width || a.height != b.height) return 0;
  for (size_t i = 0; i < a.keys.size(); ++i)
    if (a.keys[i] != b.keys[i]) return long(i);
  return -1;
}

inline std::string mismatch_text(const VisBuffer& a, const VisBuffer& b, long i) {
  std::ostringstream s;
  s << "pixel (" << i % a.width << ", " << i / a.width << "): " << std::hex << a.keys[i] << " vs "
    << b.keys[i];
  return s.str();
}

// ---- generators (pixel space; z is the depth written through the w = 1 matrix) ----

// Uniform integer in [lo, hi). rc::gen::inRange scales its range with the test size
// (early cases only see the low end); fixing the size keeps every kind and position
// equally likely while still shrinking towards `lo`.
template <typename T>
T uniform(T lo, T hi) {
  return *rc::gen::resize(100, rc::gen::inRange<T>(lo, hi));
}

inline float depth_value() {
  // (0, 1]: includes exactly 1 and tiny values; many equal depths via the small set.
  int kind = uniform(0, 4);
  if (kind == 0) return *rc::gen::element(0.25f, 0.5f, 1.0f);
  if (kind == 1) return std::ldexp(1.0f, -uniform(1, 130));  // down to denormals
  return float(uniform(1, 1 << 20)) / float(1 << 20);
}

inline Vec3 grid_point(int lo, int hi, int units_per_pixel) {
  float x = float(uniform(lo * units_per_pixel, hi * units_per_pixel)) / float(units_per_pixel);
  float y = float(uniform(lo * units_per_pixel, hi * units_per_pixel)) / float(units_per_pixel);
  return {x, y, depth_value()};
}

// A triangle in pixel coordinates around a width×height viewport.
inline Tri pixel_triangle(int width, int height) {
  int kind = uniform(0, 8);
  int size = std::max(width, height);
  Tri t;
  switch (kind) {
    case 0:  // on the 1/256 sub-pixel grid
      for (auto& v : t.v) v = grid_point(-8, size + 8, 256);
      break;
    case 1:  // on the half-pixel grid: centres exactly on edges and vertices
      for (auto& v : t.v) v = grid_point(-4, size + 4, 2);
      break;
    case 2: {  // sub-pixel: all vertices within one or two pixels
      Vec3 base = grid_point(0, size, 4);
      for (auto& v : t.v) {
        v = base;
        v.x += float(uniform(-300, 300)) / 256.0f;
        v.y += float(uniform(-300, 300)) / 256.0f;
        v.z = depth_value();
      }
      break;
    }
    case 3: {  // sliver: third vertex within a few sub-pixel units of the opposite edge
      t.v[0] = grid_point(-8, size + 8, 256);
      t.v[1] = grid_point(-8, size + 8, 256);
      float f = float(uniform(0, 257)) / 256.0f;
      t.v[2] = {t.v[0].x + f * (t.v[1].x - t.v[0].x) + float(uniform(-3, 4)) / 256.0f,
                t.v[0].y + f * (t.v[1].y - t.v[0].y) + float(uniform(-3, 4)) / 256.0f,
                depth_value()};
      break;
    }
    case 4:  // huge: far beyond the guard band (clipped there)
      for (auto& v : t.v) {
        float scale = *rc::gen::element(1e3f, 1e5f, 1e7f, 1e12f);
        v = {float(uniform(-1000, 1001)) / 1000.0f * scale + float(width) / 2,
             float(uniform(-1000, 1001)) / 1000.0f * scale + float(height) / 2, depth_value()};
      }
      break;
    case 5: {  // degenerate: repeated or exactly collinear vertices
      t.v[0] = grid_point(-4, size + 4, 2);
      t.v[1] = grid_point(-4, size + 4, 2);
      int k = uniform(-2, 3);
      t.v[2] = {t.v[0].x + float(k) * (t.v[1].x - t.v[0].x), t.v[0].y + float(k) * (t.v[1].y - t.v[0].y),
                depth_value()};
      break;
    }
    case 6: {  // axis-aligned edges (top/left rule on horizontal and vertical edges)
      Vec3 a = grid_point(-2, size + 2, 2), b = grid_point(-2, size + 2, 2);
      t.v[0] = a;
      t.v[1] = {b.x, a.y, depth_value()};
      t.v[2] = {a.x, b.y, depth_value()};
      break;
    }
    default:  // arbitrary floats
      for (auto& v : t.v)
        v = {float(uniform(-20000, size * 1000 + 20000)) / 1000.0f,
             float(uniform(-20000, size * 1000 + 20000)) / 1000.0f, depth_value()};
      break;
  }
  if (uniform(0, 4) == 0) t.v[1].z = t.v[2].z = t.v[0].z;  // constant depth
  return t;
}

// A triangle in view space (right-handed, looking down −Z) for a perspective camera;
// many cross the near plane, touch it exactly or lie behind the camera.
inline Tri view_triangle(float z_near) {
  Tri t;
  for (auto& v : t.v) {
    int kind = uniform(0, 6);
    float x = float(uniform(-4000, 4001)) / 1000.0f;
    float y = float(uniform(-4000, 4001)) / 1000.0f;
    float z;
    if (kind == 0) z = -z_near;                                           // exactly on the near plane
    else if (kind == 1) {  // at (or level with) the eye
      z = 0.0f;
      x = *rc::gen::element(0.0f, x);
      y = *rc::gen::element(0.0f, y);
    }
    else if (kind == 2) z = float(uniform(1, 4000)) / 1000.0f;  // behind the camera
    else z = -float(uniform(1, 20000)) / 1000.0f;               // in front (some nearer than z_near)
    v = {x, y, z};
  }
  // Edge-on: the third vertex on the line through the eye and the first puts the plane
  // of the triangle through the eye (it projects to a segment).
  if (uniform(0, 5) == 0) {
    float k = *rc::gen::element(0.5f, 2.0f, -1.0f, 1.0f);
    t.v[2] = {t.v[0].x * k, t.v[0].y * k, t.v[0].z * k};
  }
  return t;
}

// A triangle sharing the edge (b, a) with `prev` = (a, b, c): same facing, the fourth
// vertex on the other side or anywhere (overlaps allowed).
inline Tri neighbour_triangle(const Tri& prev, int width, int height) {
  Tri fresh = pixel_triangle(width, height);
  int e = uniform(0, 3);
  Vec3 a = prev.v[e], b = prev.v[(e + 1) % 3];
  return Tri{{b, a, fresh.v[0]}};
}

}  // namespace vgeo::raster_test
