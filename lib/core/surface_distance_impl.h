#pragma once
// Template part of surface_distance.h.
#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

namespace vgeo {

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
