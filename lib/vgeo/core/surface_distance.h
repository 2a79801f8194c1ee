#pragma once
// One-sided surface distance, shared by the builder (which stores a simplification's
// error) and lib/vgeo/verify (which checks the stored error): one implementation, so the
// checker's sample points are a subset of the builder's (spec/invariants.md §ERROR_BOUND).
//
// Sampling: on every triangle, the barycentric lattice with `subdivisions` steps per edge:
// corners, points on edges, interior points. A lattice with s steps contains the lattice
// with d steps whenever d divides s (the barycentric coordinates i/d = (i·s/d)/s round to
// the same double), so a builder sampling with a multiple of the checker's subdivision
// measures at every point the checker measures.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace vgeo {

// Depth cap of the certified error bound's subdivision (spec/invariants.md §5, ERROR_CERTIFIED):
// a triangle is split into 4 by its edge midpoints at most this many times. The builder
// (lib/vgeo/dag/leaf_certify.cpp, --error-bound certified) stores a bound certified within this depth and lib/vgeo/verify
// certifies it with the same cap, so the check never needs to go deeper than the builder did.
// 4 left bumps steeper than the cluster triangle (the generated spheres, armadillo's detail) to
// the Lipschitz bound of a 1/16-size sub-triangle, up to 10% above the continuous maximum; 6
// (1/64) brings those within 3% at no measurable build cost (docs/acceptance/issue23_certfast.md).
inline constexpr uint32_t kCertifyMaxDepth = 6;

// Lattice steps per triangle edge used by the builder to measure a simplification's error
// and by lib/vgeo/verify's ERROR_BOUND by default: the same lattice, so the stored error covers
// every point the checker samples at level 1 exactly, and by the triangle inequality
// (stored = max(member errors) + own) at every level above. 3 steps = 10 points per
// triangle, shared points once: ~4.5 distance queries per triangle.
inline constexpr uint32_t kErrorLatticeSubdivisions = 3;

struct DVec3 {
  double x = 0, y = 0, z = 0;
};

// Exact-in-double squared distance from p to triangle abc (degenerate triangles: nearest edge).
double point_triangle_distance_squared(DVec3 p, DVec3 a, DVec3 b, DVec3 c);

// Both are prepared_triangle_*(p, prepare_triangle(a, b, c)) (surface_distance_impl.h): callers
// testing many points against one triangle prepare it once, with bit-identical results.

// Same decision as `point_triangle_distance_squared(p, a, b, c) <= threshold`, bit-exactly,
// but stops at the first edge within `threshold` when p projects outside the triangle.
// `*d2` gets the exact squared distance when all of it was computed, else a value ≤ threshold.
bool point_triangle_within_squared(DVec3 p, DVec3 a, DVec3 b, DVec3 c, double threshold, double* d2);

class ThreadPool;

// Nearest-triangle queries against a fixed set of triangles (AABB tree, double). Corners and
// boxes are stored as float: every coordinate is a float input (mesh positions), and a box's
// bounds are minima and maxima of them, so widening to double on load gives the same doubles
// a double copy would, at half the memory (and fewer cache lines per query). Every query is
// exact whatever the tree's shape: the shape decides only how fast.
class TriangleDistanceTree {
 public:
  TriangleDistanceTree() = default;
  // A triangle soup, `corners`: 9 floats per triangle (3 corners × xyz), reordered into a
  // median-split tree (longest axis of the centroids). `pool` (optional; not from inside one
  // of its own tasks) builds in parallel; the tree is the same for any pool and without one.
  // Triangle ids are tree positions.
  explicit TriangleDistanceTree(std::vector<float> corners, ThreadPool* pool = nullptr);
  // Indexed triangles kept in the caller's order: `positions` (3 floats per vertex, read in
  // place: must outlive the tree) and `corner_ids` (3 vertex ids per triangle). Each node
  // splits its range of triangles at the middle, so no centroid, sort or copy of the corners
  // is made (the memory a soup tree fills is most of its build time); the caller's order must
  // be spatially coherent (clusters of a spatially ordered mesh) for the boxes to be tight.
  // Triangle ids are the caller's.
  TriangleDistanceTree(const float* positions, std::vector<uint32_t> corner_ids, ThreadPool* pool = nullptr);
  bool empty() const { return nodes_.empty(); }
  uint32_t triangle_count() const { return uint32_t(leaf_of_.size()); }
  // Corner j of triangle t (t < triangle_count()). The tree tests triangle t as
  // prepare_triangle(corner(t, 0), corner(t, 1), corner(t, 2)): a caller that looks for a
  // nearby triangle itself before asking the tree makes the same decisions with it.
  DVec3 corner(uint32_t t, int j) const {
    const float* c = positions_ ? &positions_[3 * size_t(corner_ids_[3 * size_t(t) + size_t(j)])]
                                : &corners_[9 * size_t(t) + 3 * size_t(j)];
    return {c[0], c[1], c[2]};
  }
  // Squared distance to the nearest triangle; `hint` (in/out) is a triangle to start from
  // (pass ~0u initially; an opaque tree position); +inf when empty.
  double nearest_distance_squared(DVec3 p, uint32_t* hint) const;
  // nearest_distance_squared(p, hint), or, as soon as its search finds a triangle within
  // sqrt(threshold) of p, that triangle's squared distance (≤ threshold): whether some
  // triangle lies within (result ≤ threshold, the decision of nearest_distance_squared(p) <=
  // threshold, bit-exactly) and, when none does, the nearest distance, in one search.
  // `hint` (in/out, as above) gets the triangle found.
  double nearest_or_within_squared(DVec3 p, double threshold, uint32_t* hint) const;
  // The same search, and `*unchanged_below` (lowered, never raised) gets the smallest distance
  // it compared with the threshold and found beyond it (+inf: none): the result and the hint
  // are the same for every threshold from this one up to below that value (a parallel
  // measurement's check of an assumed threshold: leaf_error.cpp).
  double nearest_or_within_squared(DVec3 p, double threshold, uint32_t* hint, double* unchanged_below) const;
  // Appends to `out` every triangle whose box (over its corners) meets the closed box
  // [lo, hi] and that has a corner on each side of the slab {x : |normal·x - offset| <= width}
  // or in it (normal: any vector; width 0 and normal 0 accept all), in tree order (the same
  // list for any tree build). Stops once `out` holds more than `max_count` (the caller then
  // ignores the list).
  void triangles_in_box(DVec3 lo, DVec3 hi, std::vector<uint32_t>* out, DVec3 normal = {}, double offset = 0,
                        double width = 0, size_t max_count = ~size_t(0)) const;
  // Corner j (0..2) of triangle t (an id from the queries above: tree order).
  DVec3 triangle_corner(uint32_t t, int j) const { return corner(t, j); }
  // The caller's vertex id of corner j of triangle t (indexed trees only).
  uint32_t triangle_corner_id(uint32_t t, int j) const { return corner_ids_[3 * size_t(t) + size_t(j)]; }
  // The float bits of corner j of triangle t (x, y, z): identical positions, identical keys.
  const float* triangle_corner_floats(uint32_t t, int j) const {
    return positions_ ? &positions_[3 * size_t(corner_ids_[3 * size_t(t) + size_t(j)])]
                      : &corners_[9 * size_t(t) + 3 * size_t(j)];
  }

 private:
  template <bool kTrack>
  double search_within(DVec3 p, double threshold, uint32_t* hint, double* unchanged_below) const;
  struct Node {
    float lo[3];
    uint32_t first = 0;  // leaf: triangles [first, +count); inner: children first, first+1
    float hi[3];
    uint32_t count = 0;
  };
  // Build-time, per triangle in tree order: its centroid and input index. The splits reorder
  // these (not indices into a centroid array): their keys are read in sequence.
  struct BuildItem {
    double centroid[3];
    uint32_t triangle;
  };
  // Where a subtree goes: its node, its triangles [first, last) of the build items, and
  // `next`, the first node index of its descendants (children pairs are laid out depth first).
  struct Subtree {
    uint32_t index, first, last, next;
  };
  // items == nullptr: the order is kept, ranges split at the middle.
  static uint32_t split(BuildItem* items, uint32_t first, uint32_t last);
  uint32_t build(Subtree at, BuildItem* items);
  // The structure over n triangles (nodes_, splits reordering `items` if given); returns the
  // independently built subtrees and the inner nodes above them (parents before children).
  void build_structure(uint32_t n, ThreadPool* pool, BuildItem* items, std::vector<Subtree>& frontier,
                       std::vector<Subtree>& top);
  // Boxes bottom up, parent_ and leaf_of_, once the corners are in place.
  void finish(uint32_t n, ThreadPool* pool, const std::vector<Subtree>& frontier, const std::vector<Subtree>& top);
  void set_box(uint32_t index);
  double triangle_d2(DVec3 p, uint32_t t) const;
  std::vector<float> corners_;  // soup: 9 per triangle, in tree order
  const float* positions_ = nullptr;   // indexed: the caller's positions
  std::vector<uint32_t> corner_ids_;   // indexed: 3 per triangle
  uint32_t leaf_size_ = 0;             // triangles per tree leaf (at most)
  std::vector<Node> nodes_;
  std::vector<uint32_t> parent_;   // per node (root: 0)
  std::vector<uint32_t> leaf_of_;  // per triangle: its tree leaf
};

// Calls visit(point) once for every lattice point of the triangles (corner points once per
// distinct referenced vertex, edge points once per distinct edge, interior points per
// triangle). `positions` has 3 floats per vertex; `indices` 3 per triangle.
template <class Visit>
void for_each_lattice_point(const float* positions, const uint32_t* indices, size_t triangle_count,
                            uint32_t subdivisions, Visit&& visit);

// max over the lattice points of `from` of the distance to `to` (0 if `from` is empty).
double sampled_one_sided_distance(const float* positions, const uint32_t* from_indices, size_t from_triangles,
                                  const TriangleDistanceTree& to, uint32_t subdivisions);

}  // namespace vgeo

#include "vgeo/core/surface_distance_impl.h"
