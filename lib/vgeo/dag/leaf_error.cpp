// A simplified group's deviation from the original surface (spec/dag.md §Error): the stored
// error is what lib/vgeo/verify measures (ERROR_BOUND), so the builder measures the same thing
// the same way: every lattice point of the simplified triangles (lib/vgeo/core/surface_distance.h,
// kErrorLatticeSubdivisions, the same point coordinates) against *all* leaf triangles, exact
// nearest distance in double. Measuring against the group's input (its children) and adding
// the children's error instead sums one bound per level: honest, but loose (issue 15 §2).
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

float round_up_to_float(double d) {
  float e = float(d);
  if (double(e) < d) e = std::nextafter(e, std::numeric_limits<float>::infinity());
  return e;
}

}  // namespace

LeafSurface build_leaf_surface(const Mesh& mesh, const std::vector<const TriangleSet*>& leaves) {
  size_t n = 0;
  for (const TriangleSet* t : leaves) n += t->triangle_count();
  std::vector<DVec3> corners;
  corners.reserve(3 * n);
  for (const TriangleSet* t : leaves)
    for (uint32_t v : t->corners)
      corners.push_back({mesh.positions[3 * size_t(v)], mesh.positions[3 * size_t(v) + 1], mesh.positions[3 * size_t(v) + 2]});
  LeafSurface s;
  s.tree = TriangleDistanceTree(std::move(corners));
  return s;
}

float leaf_deviation(const LeafSurface& leaves, const Mesh& mesh, const TriangleSet& simplified, float floor) {
  if (leaves.tree.empty() || simplified.triangle_count() == 0) return floor;
  // A float squared is exact in double, and sqrt and the rounding up are monotonic: a
  // maximum ≤ floor² rounds to ≤ floor, so points within the floor cannot change the result.
  const double floor_d2 = std::isfinite(floor) && floor > 0 ? double(floor) * double(floor) : 0.0;
  double best2 = 0.0;
  uint32_t hint = ~0u;  // the last leaf triangle found: lattice points come in spatial runs
  // The points lib/vgeo/verify samples (the same function): corners, edge points once per
  // distinct edge, interior points.
  for_each_lattice_point(mesh.positions.data(), simplified.corners.data(), simplified.triangle_count(),
                         kErrorLatticeSubdivisions, [&](DVec3 p) {
                           const double threshold = std::max(best2, floor_d2);
                           if (leaves.tree.any_within_squared(p, threshold, &hint)) return;
                           best2 = std::max(best2, leaves.tree.nearest_distance_squared(p, &hint));
                         });
  return std::max(floor, round_up_to_float(std::sqrt(best2)));
}

}  // namespace vgeo::build_detail
