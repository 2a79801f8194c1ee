#pragma once
// Independent topology checks for generator/subdivision/export tests: welded by exact
// position (not by index), so they also catch cracks hidden by duplicated vertices.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <numeric>
#include <unordered_map>
#include <vector>

#include "vgeo/core/hash.h"
#include "vgeo/mesh/mesh.h"

namespace vgeo::test {

// Vertex -> id of the first vertex with bit-identical position.
inline std::vector<uint32_t> weld_by_position(const Mesh& m) {
  std::map<std::array<uint32_t, 3>, uint32_t> first;
  std::vector<uint32_t> id(m.vertex_count());
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    std::array<uint32_t, 3> key;
    std::memcpy(key.data(), &m.positions[3 * v], 12);
    id[v] = first.emplace(key, uint32_t(v)).first->second;
  }
  return id;
}

struct EdgeCounts {
  size_t edges = 0;               // undirected welded edges
  size_t boundary = 0;            // used by one triangle
  size_t non_manifold = 0;        // used by more than two triangles
  size_t unpaired_directed = 0;   // directed edge (a,b) without exactly one (b,a) partner
  size_t repeated_directed = 0;   // directed edge used twice (inconsistent orientation)
  std::vector<std::pair<uint32_t, uint32_t>> boundary_edges;  // welded ids
};

inline EdgeCounts count_edges(const Mesh& m) {
  const std::vector<uint32_t> id = weld_by_position(m);
  std::unordered_map<uint64_t, uint32_t> directed;
  directed.reserve(m.indices.size());
  for (size_t t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      uint64_t a = id[m.indices[3 * t + k]], b = id[m.indices[3 * t + (k + 1) % 3]];
      ++directed[a << 32 | b];
    }
  EdgeCounts e;
  for (auto& [key, n] : directed) {
    uint64_t a = key >> 32, b = key & 0xffffffffu;
    auto it = directed.find(b << 32 | a);
    uint32_t back = it == directed.end() ? 0 : it->second;
    if (n > 1) ++e.repeated_directed;
    if (n != 1 || back != 1) ++e.unpaired_directed;
    if (a < b || back == 0) {
      ++e.edges;
      uint32_t total = n + back;
      if (total == 1) ++e.boundary, e.boundary_edges.emplace_back(uint32_t(a), uint32_t(b));
      if (total > 2) ++e.non_manifold;
    }
  }
  return e;
}

// Closed, consistently oriented 2-manifold (edge-wise): every directed welded edge has
// exactly one opposite partner and is used once.
inline bool is_closed_oriented_manifold(const Mesh& m) {
  EdgeCounts e = count_edges(m);
  return e.unpaired_directed == 0 && e.boundary == 0 && e.non_manifold == 0;
}

inline double signed_volume(const Mesh& m) {
  double vol = 0;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    Vec3 a = m.position(m.indices[3 * t]), b = m.position(m.indices[3 * t + 1]), c = m.position(m.indices[3 * t + 2]);
    vol += (double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) - double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
            double(a.z) * (double(b.x) * c.y - double(b.y) * c.x)) / 6.0;
  }
  return vol;
}

// Connected components over triangles, vertices welded by position. comp[t] per triangle.
inline size_t triangle_components(const Mesh& m, std::vector<uint32_t>* comp = nullptr) {
  const std::vector<uint32_t> id = weld_by_position(m);
  std::vector<uint32_t> parent(m.vertex_count());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    uint32_t r0 = find(id[m.indices[3 * t]]);
    for (int k = 1; k < 3; ++k) {
      uint32_t r = find(id[m.indices[3 * t + k]]);
      if (r != r0) parent[r] = r0;
    }
  }
  std::unordered_map<uint32_t, uint32_t> label;
  if (comp) comp->resize(m.triangle_count());
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    uint32_t r = find(id[m.indices[3 * t]]);
    auto it = label.emplace(r, uint32_t(label.size())).first;
    if (comp) (*comp)[t] = it->second;
  }
  return label.size();
}

inline uint64_t mesh_hash(const Mesh& m) {
  uint64_t h = kFnvOffset;
  h = fnv1a64(m.positions.data(), m.positions.size() * 4, h);
  h = fnv1a64(m.normals.data(), m.normals.size() * 4, h);
  h = fnv1a64(m.uvs.data(), m.uvs.size() * 4, h);
  h = fnv1a64(m.indices.data(), m.indices.size() * 4, h);
  h = fnv1a64(m.materials.data(), m.materials.size() * 4, h);
  return h;
}

}  // namespace vgeo::test
