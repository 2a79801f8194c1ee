// A simplification's own error, measured (spec/dag.md §Error).
//
// The stored error must cover every lattice point lib/verify samples (ERROR_BOUND), so the
// builder measures at every point of the kErrorLatticeSubdivisions lattice of the simplified
// triangles and takes the exact nearest-triangle distance of lib/core/surface_distance.h
// (same point coordinates, same point_triangle_distance_squared). What is cheap here is only
// *how* the maximum is found: the result is max(estimate, max over points of min over
// triangles), so a point whose distance to *some* input triangle is already ≤ the running
// maximum cannot change it and needs no nearest search (the early break of exact Hausdorff
// distance algorithms). Candidates are tried first (the last nearest triangle, then the
// input triangles incident to the simplified triangle's corners, nearest corner first);
// only a point farther than the running maximum from all of them gets the exact tree search.
#include <algorithm>
#include <cmath>
#include <limits>

#include "vgeo/build/build_internal.h"
#include "vgeo/core/surface_distance.h"

namespace vgeo::build_detail {

namespace {

float round_up_to_float(double d) {
  float e = float(d);
  if (double(e) < d) e = std::nextafter(e, std::numeric_limits<float>::infinity());
  return e;
}

// Max over the lattice points of `simplified` of the squared distance to `input`'s
// triangles, or any value ≤ floor_d2 when that maximum is ≤ floor_d2.
double max_lattice_d2_above(const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified,
                            double floor_d2) {
  const size_t n = input.triangle_count();
  if (n == 0 || simplified.triangle_count() == 0) return 0.0;
  const float* pos = mesh.positions.data();
  auto vertex = [&](uint32_t v) { return DVec3{pos[3 * size_t(v)], pos[3 * size_t(v) + 1], pos[3 * size_t(v) + 2]}; };
  std::vector<DVec3> corners(3 * n);
  for (size_t i = 0; i < corners.size(); ++i) corners[i] = vertex(input.corners[i]);
  // Input triangles incident to each input vertex id: (vertex, triangle) sorted by vertex.
  std::vector<std::pair<uint32_t, uint32_t>> incident(3 * n);
  for (size_t i = 0; i < 3 * n; ++i) incident[i] = {input.corners[i], uint32_t(i / 3)};
  std::sort(incident.begin(), incident.end());

  auto tri_d2 = [&](DVec3 p, uint32_t t) {
    const DVec3* c = &corners[3 * size_t(t)];
    return point_triangle_distance_squared(p, c[0], c[1], c[2]);
  };
  TriangleDistanceTree tree;  // built on the first point that needs an exact search
  bool tree_built = false;
  double best2 = 0.0;
  uint32_t hint = 0;
  // Candidate rings: input triangles incident to each corner of the simplified triangle.
  std::vector<uint32_t> ring[3];

  // `first_ring`: the corner nearest to p (its ring is tried first).
  auto visit = [&](DVec3 p, int first_ring) {
    const double threshold = std::max(best2, floor_d2);
    double d = tri_d2(p, hint);
    if (d <= threshold) return;
    uint32_t nearest = hint;
    for (int r = 0; r < 3; ++r)
      for (uint32_t t : ring[(first_ring + r) % 3]) {
        double dt = tri_d2(p, t);
        if (dt <= threshold) {
          hint = t;
          return;
        }
        if (dt < d) d = dt, nearest = t;
      }
    // No candidate is within the running maximum: the exact minimum over all triangles.
    if (!tree_built) {
      tree = TriangleDistanceTree(corners);
      tree_built = true;
    }
    uint32_t h = nearest;
    double exact = tree.nearest_distance_squared(p, &h);
    hint = h;
    if (exact > best2) best2 = exact;
  };

  const uint32_t s = kErrorLatticeSubdivisions ? kErrorLatticeSubdivisions : 1;
  for (size_t t = 0; t < simplified.triangle_count(); ++t) {
    const uint32_t* tri = &simplified.corners[3 * t];
    for (int j = 0; j < 3; ++j) {
      ring[j].clear();
      auto lo = std::lower_bound(incident.begin(), incident.end(), std::make_pair(tri[j], 0u));
      for (auto it = lo; it != incident.end() && it->first == tri[j]; ++it) ring[j].push_back(it->second);
    }
    DVec3 a = vertex(tri[0]), b = vertex(tri[1]), c = vertex(tri[2]);
    // Corner points are skipped: a simplified corner is an input vertex (both backends only
    // remove vertices), i.e. a corner of an input triangle, where
    // point_triangle_distance_squared returns exactly 0 (ap = 0 in both branches), which
    // cannot raise a maximum that starts at 0. Edge and interior points have the coordinates
    // for_each_lattice_point computes (edges from the smaller vertex id), so every point is
    // bit-identical to the one lib/verify samples. Points of shared edges are visited once
    // per triangle: repeats cannot change a maximum.
    for (int j = 0; j < 3; ++j) {
      const int k = (j + 1) % 3;
      const bool forward = tri[j] <= tri[k];
      uint32_t i0 = forward ? tri[j] : tri[k], i1 = forward ? tri[k] : tri[j];
      DVec3 e0 = vertex(i0), e1 = vertex(i1);
      for (uint32_t i = 1; i < s; ++i) {
        double f = double(i) / s;
        bool near_e0 = 2 * i <= s;
        visit(DVec3{e0.x + (e1.x - e0.x) * f, e0.y + (e1.y - e0.y) * f, e0.z + (e1.z - e0.z) * f},
              near_e0 == forward ? j : k);
      }
    }
    for (uint32_t u = 1; u < s; ++u)
      for (uint32_t w = 1; u + w < s; ++w) {
        double bu = double(u) / s, bw = double(w) / s, bv = 1.0 - bu - bw;
        int first_ring = bv >= bu && bv >= bw ? 0 : (bu >= bw ? 1 : 2);
        visit(DVec3{a.x * bv + b.x * bu + c.x * bw, a.y * bv + b.y * bu + c.y * bw, a.z * bv + b.z * bu + c.z * bw},
              first_ring);
      }
  }
  return best2;
}

}  // namespace

float measured_simplification_error(const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified) {
  return round_up_to_float(std::sqrt(max_lattice_d2_above(mesh, input, simplified, 0.0)));
}

float simplification_error(const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified,
                           float estimate) {
  // A float squared is exact in double (24-bit mantissa → 48 bits), and sqrt and the
  // rounding up are monotonic, so any measured value ≤ estimate² rounds to ≤ estimate: the
  // search may stop below the floor without changing max(estimate, measured).
  double floor_d2 = std::isfinite(estimate) && estimate > 0 ? double(estimate) * double(estimate) : 0.0;
  float measured = round_up_to_float(std::sqrt(max_lattice_d2_above(mesh, input, simplified, floor_d2)));
  return std::max(estimate, measured);
}

}  // namespace vgeo::build_detail
