// A simplified group's deviation from the original surface (spec/dag.md §Error): the stored
// error is what lib/vgeo/verify measures (ERROR_BOUND), so the builder measures the same thing
// the same way: every lattice point of the simplified triangles (lib/vgeo/core/surface_distance.h,
// kErrorLatticeSubdivisions, the same point coordinates) against *all* leaf triangles, exact
// nearest distance in double. Measuring against the group's input (its children) and adding
// the children's error instead sums one bound per level: honest, but loose (measured:
// docs/acceptance/issue15.md §2).
// Based on: Cignoni, Rocchini, Scopigno, "Metro: Measuring Error on Simplified Surfaces",
// Computer Graphics Forum 17(2), 1998 (one-sided distance of sample points to the original
// surface); Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Error metric" (a mesh
// distance instead of the quadrics' estimate).
//
// Only the maximum is wanted, and only above a floor (the children's stored error, which the
// parent's stored error takes the max with anyway): a point with *some* leaf triangle within
// the running threshold cannot raise the maximum and needs no nearest search. Candidates are
// tried first (the last leaf triangle found), then the tree's any-within query; only a point
// farther than the threshold from every leaf gets the exact nearest search.
#include <algorithm>
#include <cmath>
#include <limits>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

// Empty slot of the edge set (no edge has both ends ~0u: vertex ids are < 2^32 - 1).
constexpr uint64_t kNoEdge = ~uint64_t(0);

}  // namespace

LeafSurface build_leaf_surface(const Mesh& mesh, const std::vector<const TriangleSet*>& leaves, ThreadPool& pool) {
  std::vector<size_t> offset(leaves.size() + 1, 0);  // per leaf: its first corner float
  for (size_t i = 0; i < leaves.size(); ++i) offset[i + 1] = offset[i] + 3 * leaves[i]->corners.size();
  std::vector<float> corners(offset.back());
  pool.parallel_for(leaves.size(), [&](size_t i) {
    float* out = &corners[offset[i]];
    for (uint32_t v : leaves[i]->corners) out = std::copy_n(&mesh.positions[3 * size_t(v)], 3, out);
  });
  LeafSurface s;
  s.tree = TriangleDistanceTree(std::move(corners), &pool);
  return s;
}

float leaf_deviation(const LeafSurface& leaves, const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified,
                     float floor) {
  if (leaves.tree.empty() || simplified.triangle_count() == 0) return floor;
  // A float squared is exact in double, and sqrt and the rounding up are monotonic: a
  // maximum ≤ floor² rounds to ≤ floor, so points within the floor cannot change the result.
  const double floor_d2 = std::isfinite(floor) && floor > 0 ? double(floor) * double(floor) : 0.0;
  // Edges (by original vertex ids, smaller first: the lattice points depend on both) whose
  // points need no visit: edges of the input when the input is itself simplified (floor > 0)
  // — the same points were measured for the members, within their stored error ≤ floor —
  // and edges already visited. Open addressing, load ≤ 1/2.
  size_t slots = 16;
  int shift = 60;  // hash = top log2(slots) bits of a multiplicative hash
  while (slots < 6 * (simplified.triangle_count() + (floor_d2 > 0 ? input.triangle_count() : 0))) slots <<= 1, --shift;
  std::vector<uint64_t> edge_slot(slots, kNoEdge);
  auto insert_edge = [&](uint32_t a, uint32_t b) {  // true iff the edge was not in the set
    const uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
    size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> shift);
    while (edge_slot[h] != kNoEdge) {
      if (edge_slot[h] == key) return false;
      h = (h + 1) & (slots - 1);
    }
    edge_slot[h] = key;
    return true;
  };
  if (floor_d2 > 0)
    for (size_t t = 0; t < input.triangle_count(); ++t)
      for (int j = 0; j < 3; ++j) insert_edge(input.corners[3 * t + j], input.corners[3 * t + (j + 1) % 3]);

  double best2 = 0.0;
  uint32_t hint = ~0u;  // the last leaf triangle found: the points of a triangle come together
  auto visit = [&](DVec3 p) {
    const double threshold = std::max(best2, floor_d2);
    if (leaves.tree.any_within_squared(p, threshold, &hint)) return;
    best2 = std::max(best2, leaves.tree.nearest_distance_squared(p, &hint));
  };
  auto vertex = [&](uint32_t v) {
    return DVec3{mesh.positions[3 * size_t(v)], mesh.positions[3 * size_t(v) + 1], mesh.positions[3 * size_t(v) + 2]};
  };
  // The points of for_each_lattice_point (lib/vgeo/core/surface_distance.h, which
  // lib/vgeo/verify samples), same formulas, triangle by triangle. Corners are skipped: a
  // simplified corner is an input vertex (both backends only remove vertices), a corner of a
  // leaf triangle, at distance exactly 0.
  const uint32_t s = kErrorLatticeSubdivisions ? kErrorLatticeSubdivisions : 1;
  for (size_t t = 0; t < simplified.triangle_count(); ++t) {
    const uint32_t* tri = &simplified.corners[3 * t];
    for (int j = 0; j < 3; ++j) {
      if (!insert_edge(tri[j], tri[(j + 1) % 3])) continue;
      const DVec3 e0 = vertex(std::min(tri[j], tri[(j + 1) % 3])), e1 = vertex(std::max(tri[j], tri[(j + 1) % 3]));
      for (uint32_t i = 1; i < s; ++i) {
        const double f = double(i) / s;
        visit(DVec3{e0.x + (e1.x - e0.x) * f, e0.y + (e1.y - e0.y) * f, e0.z + (e1.z - e0.z) * f});
      }
    }
    const DVec3 a = vertex(tri[0]), b = vertex(tri[1]), c = vertex(tri[2]);
    for (uint32_t u = 1; u < s; ++u)
      for (uint32_t w = 1; u + w < s; ++w) {
        const double bu = double(u) / s, bw = double(w) / s, bv = 1.0 - bu - bw;
        visit(DVec3{a.x * bv + b.x * bu + c.x * bw, a.y * bv + b.y * bu + c.y * bw, a.z * bv + b.z * bu + c.z * bw});
      }
  }
  return std::max(floor, round_up_to_float(std::sqrt(best2)));
}

}  // namespace vgeo::build_detail
