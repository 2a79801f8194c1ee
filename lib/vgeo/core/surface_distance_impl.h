#pragma once
// Template part of surface_distance.h.
#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

namespace vgeo {

// The parts of point_triangle_distance_squared that depend only on the triangle, computed
// once by callers that test many points against the same triangle. Every value is the one
// the per-call code computes (same operations, same order), so results are bit-identical.
struct PreparedTriangle {
  DVec3 a, b, c;
  DVec3 ab, bc, ca;            // b - a, c - b, a - c (segment directions)
  DVec3 n;                     // cross(b - a, c - a)
  double nn;                   // dot(n, n)
  double ab2, bc2, ca2;        // squared edge lengths
};

namespace surface_distance_detail {
inline DVec3 sub(DVec3 a, DVec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline double dot(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline DVec3 cross(DVec3 a, DVec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
// Squared distance from p to segment a + t·ab, t ∈ [0, 1] (len2 = dot(ab, ab)).
inline double point_segment_d2(DVec3 p, DVec3 a, DVec3 ab, double len2) {
  DVec3 ap = sub(p, a);
  double t = len2 > 0 ? std::clamp(dot(ap, ab) / len2, 0.0, 1.0) : 0.0;
  DVec3 q{a.x + ab.x * t - p.x, a.y + ab.y * t - p.y, a.z + ab.z * t - p.z};
  return dot(q, q);
}
}  // namespace surface_distance_detail

inline PreparedTriangle prepare_triangle(DVec3 a, DVec3 b, DVec3 c) {
  using namespace surface_distance_detail;
  PreparedTriangle t;
  t.a = a, t.b = b, t.c = c;
  t.ab = sub(b, a), t.bc = sub(c, b), t.ca = sub(a, c);
  t.n = cross(t.ab, sub(c, a));
  t.nn = dot(t.n, t.n);
  t.ab2 = dot(t.ab, t.ab), t.bc2 = dot(t.bc, t.bc), t.ca2 = dot(t.ca, t.ca);
  return t;
}

// Where p lies seen along the triangle's normal, the region test of the point-triangle
// distance: kProjectsInside when p projects into the triangle (its distance is then the
// plane's, prepared_plane_distance_squared), else the first edge (0: ab, 1: bc, 2: ca) whose
// side test puts p outside, or kNoNormal for a degenerate triangle; in those two cases the
// distance is the nearest edge's. Callers walking over a mesh cross the edge returned.
inline constexpr int kProjectsInside = -1;
inline constexpr int kNoNormal = 3;
namespace surface_distance_detail {
// The region test's side test: whether p lies outside the edge from `from` along `edge`, seen
// along n. `!(x >= 0)`, not `x < 0`: a NaN fails the test, as it fails `x >= 0`.
inline bool outside_edge(DVec3 p, DVec3 from, DVec3 edge, DVec3 n) { return !(dot(cross(edge, sub(p, from)), n) >= 0); }
}  // namespace surface_distance_detail

inline int prepared_triangle_region(DVec3 p, const PreparedTriangle& t) {
  using namespace surface_distance_detail;
  if (!(t.nn > 0)) return kNoNormal;
  if (outside_edge(p, t.a, t.ab, t.n)) return 0;
  if (outside_edge(p, t.b, t.bc, t.n)) return 1;
  if (outside_edge(p, t.c, t.ca, t.n)) return 2;
  return kProjectsInside;
}

// prepared_triangle_region(p, prepare_triangle(a, b, c)) computing only what its tests reach
// (the same operations on the same values, so the same region): a walk over a mesh leaves
// most triangles after their first side test, and needs none of the squared edge lengths.
inline int triangle_region(DVec3 p, DVec3 a, DVec3 b, DVec3 c) {
  using namespace surface_distance_detail;
  const DVec3 ab = sub(b, a);
  const DVec3 n = cross(ab, sub(c, a));
  if (!(dot(n, n) > 0)) return kNoNormal;
  if (outside_edge(p, a, ab, n)) return 0;
  if (outside_edge(p, b, sub(c, b), n)) return 1;
  if (outside_edge(p, c, sub(a, c), n)) return 2;
  return kProjectsInside;
}

// The distance from p to the triangle's plane, squared: its distance when the region is
// kProjectsInside.
inline double prepared_plane_distance_squared(DVec3 p, const PreparedTriangle& t) {
  using namespace surface_distance_detail;
  const double h = dot(t.n, sub(p, t.a));
  return h * h / t.nn;
}

// point_triangle_within_squared on a prepared triangle (the one implementation of both
// point_triangle_* functions).
// `unchanged_below` (optional, lowered only): the smallest distance compared with the threshold
// and found beyond it, below which any threshold gives the same result and *d2.
inline bool prepared_triangle_within_squared(DVec3 p, const PreparedTriangle& t, double threshold, double* d2,
                                             double* unchanged_below = nullptr) {
  using namespace surface_distance_detail;
  auto beyond = [&](double d) {
    if (unchanged_below) *unchanged_below = std::min(*unchanged_below, d);
  };
  if (prepared_triangle_region(p, t) == kProjectsInside) {
    *d2 = prepared_plane_distance_squared(p, t);
    if (*d2 <= threshold) return true;
    beyond(*d2);
    return false;
  }
  // min of the three segment distances ≤ threshold iff one of them is.
  double d = point_segment_d2(p, t.a, t.ab, t.ab2);
  if (d <= threshold) return *d2 = d, true;
  beyond(d);
  d = std::min(d, point_segment_d2(p, t.b, t.bc, t.bc2));
  if (d <= threshold) return *d2 = d, true;
  beyond(d);
  d = std::min(d, point_segment_d2(p, t.c, t.ca, t.ca2));
  *d2 = d;
  if (d <= threshold) return true;
  beyond(d);
  return false;
}

inline double prepared_triangle_distance_squared(DVec3 p, const PreparedTriangle& t) {
  using namespace surface_distance_detail;
  if (prepared_triangle_region(p, t) == kProjectsInside) return prepared_plane_distance_squared(p, t);
  return std::min({point_segment_d2(p, t.a, t.ab, t.ab2), point_segment_d2(p, t.b, t.bc, t.bc2),
                   point_segment_d2(p, t.c, t.ca, t.ca2)});
}

template <class Visit>
void for_each_lattice_point(const float* positions, const uint32_t* indices, size_t triangle_count,
                            uint32_t subdivisions, Visit&& visit) {
  const uint32_t s = subdivisions ? subdivisions : 1;
  auto vertex = [&](uint32_t v) {
    return DVec3{positions[3 * size_t(v)], positions[3 * size_t(v) + 1], positions[3 * size_t(v) + 2]};
  };
  std::vector<uint32_t> corners(indices, indices + 3 * triangle_count);
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  edges.reserve(3 * triangle_count);
  for (size_t t = 0; t < triangle_count; ++t) {
    const uint32_t* tri = indices + 3 * t;
    for (int j = 0; j < 3; ++j) edges.emplace_back(std::min(tri[j], tri[(j + 1) % 3]), std::max(tri[j], tri[(j + 1) % 3]));
    DVec3 a = vertex(tri[0]), b = vertex(tri[1]), c = vertex(tri[2]);
    for (uint32_t u = 1; u < s; ++u)
      for (uint32_t w = 1; u + w < s; ++w) {
        double bu = double(u) / s, bw = double(w) / s, bv = 1.0 - bu - bw;
        visit(DVec3{a.x * bv + b.x * bu + c.x * bw, a.y * bv + b.y * bu + c.y * bw, a.z * bv + b.z * bu + c.z * bw});
      }
  }
  std::sort(corners.begin(), corners.end());
  corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
  for (uint32_t v : corners) visit(vertex(v));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  for (auto [i0, i1] : edges) {
    DVec3 a = vertex(i0), b = vertex(i1);
    for (uint32_t i = 1; i < s; ++i) {
      double t = double(i) / s;
      visit(DVec3{a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t});
    }
  }
}

}  // namespace vgeo
