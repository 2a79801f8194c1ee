// TriangleDistanceTree (lib/vgeo/core/surface_distance.h): its queries are the brute-force
// minimum over all triangles bit-exactly, for any start hint, and the tree a pool builds in
// parallel answers exactly as the serial build; the same for the indexed, order-keeping tree
// (any order: its shape decides only the speed), whose corner() is the soup's corner.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "vgeo/core/surface_distance.h"
#include "vgeo/core/thread_pool.h"

namespace vgeo {
namespace {

double brute_nearest(const std::vector<float>& c, DVec3 p) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t t = 0; t < c.size() / 9; ++t) {
    const float* q = &c[9 * t];
    best = std::min(best, point_triangle_distance_squared(p, {q[0], q[1], q[2]}, {q[3], q[4], q[5]}, {q[6], q[7], q[8]}));
  }
  return best;
}

// 20 random query points against both trees: the nearest distance equals brute force, and
// nearest_or_within_squared decides "within" at the distance itself and one ulp either side
// exactly (from the last hint and from a fresh one), giving the nearest distance when not within.
void expect_queries_equal_brute_force(const TriangleDistanceTree& serial, const TriangleDistanceTree& parallel,
                                      const std::vector<float>& corners) {
  uint32_t hint_serial = ~0u, hint_parallel = ~0u, hint_any = ~0u;
  for (int k = 0; k < 20; ++k) {
    const DVec3 p{double(*rc::gen::inRange(-80, 81)) / 32, double(*rc::gen::inRange(-80, 81)) / 32,
                  double(*rc::gen::inRange(-80, 81)) / 32};
    const double expected = brute_nearest(corners, p);
    RC_ASSERT(serial.nearest_distance_squared(p, &hint_serial) == expected);
    RC_ASSERT(parallel.nearest_distance_squared(p, &hint_parallel) == expected);
    // The decision at the distance itself and one ulp either side, from the last hint.
    for (double threshold : {expected, std::nextafter(expected, 0.0), std::nextafter(expected, 1e300)}) {
      // Within: some distance ≤ threshold; else the nearest, exactly.
      const double hinted = parallel.nearest_or_within_squared(p, threshold, &hint_any);
      RC_ASSERT((hinted <= threshold) == (expected <= threshold));
      RC_ASSERT((hinted <= threshold || hinted == expected));
      uint32_t fresh = ~0u;
      const double unhinted = serial.nearest_or_within_squared(p, threshold, &fresh);
      RC_ASSERT((unhinted <= threshold) == (expected <= threshold));
      RC_ASSERT((unhinted <= threshold || unhinted == expected));
    }
  }
}

// Corners on a coarse grid (coincident, collinear and degenerate triangles common), enough
// triangles that a pool of 3 splits the top of the tree in parallel (8 subtrees per thread).
RC_GTEST_PROP(TriangleDistanceTree, QueriesEqualBruteForceForAnyPool, ()) {
  const uint32_t triangles = *rc::gen::inRange<uint32_t>(1, 400);
  std::vector<float> corners;
  for (uint32_t i = 0; i < 9 * triangles; ++i) corners.push_back(float(*rc::gen::inRange(-8, 9)) * 0.25f);
  ThreadPool pool(3);
  const TriangleDistanceTree serial(corners), parallel(corners, &pool);
  expect_queries_equal_brute_force(serial, parallel, corners);
}

// Indexed triangles over a few grid vertices (shared, repeated and collinear corners), in
// the caller's random order (no spatial coherence at all).
RC_GTEST_PROP(TriangleDistanceTree, IndexedTreeQueriesEqualBruteForceForAnyPool, ()) {
  const uint32_t vertices = *rc::gen::inRange<uint32_t>(3, 60), triangles = *rc::gen::inRange<uint32_t>(1, 400);
  std::vector<float> positions, corners;
  for (uint32_t i = 0; i < 3 * vertices; ++i) positions.push_back(float(*rc::gen::inRange(-8, 9)) * 0.25f);
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < 3 * triangles; ++i) {
    ids.push_back(*rc::gen::inRange<uint32_t>(0, vertices));
    corners.insert(corners.end(), &positions[3 * size_t(ids.back())], &positions[3 * size_t(ids.back())] + 3);
  }
  ThreadPool pool(3);
  const TriangleDistanceTree serial(positions.data(), ids), parallel(positions.data(), ids, &pool);
  RC_ASSERT(serial.triangle_count() == triangles);
  for (uint32_t t = 0; t < triangles; ++t)
    for (int j = 0; j < 3; ++j) {
      const DVec3 c = parallel.corner(t, j);
      RC_ASSERT(c.x == corners[9 * t + 3 * j] && c.y == corners[9 * t + 3 * j + 1] && c.z == corners[9 * t + 3 * j + 2]);
    }
  expect_queries_equal_brute_force(serial, parallel, corners);
}

// triangle_region (the walk's side tests from the corners, computing only what they reach)
// decides as prepared_triangle_region on the prepared triangle, for points where the side
// tests are closest to 0: the corners, points on the edges and on their lines (the lattice
// points of surface_distance.h), the centroid, those moved by an ulp, and grid points, on
// triangles from a coarse grid (slivers, collinear and repeated corners: no normal) and on
// fine, random ones.
RC_GTEST_PROP(TriangleRegion, FromCornersEqualsPrepared, ()) {
  const bool coarse = *rc::gen::arbitrary<bool>();
  auto coordinate = [&] {
    return coarse ? double(float(*rc::gen::inRange(-4, 5)) * 0.5f) : double(float(*rc::gen::inRange(-100000, 100001)) * 1e-5f);
  };
  auto point = [&] { return DVec3{coordinate(), coordinate(), coordinate()}; };
  const DVec3 a = point(), b = point(), c = point();
  const PreparedTriangle prepared = prepare_triangle(a, b, c);
  std::vector<DVec3> points{a, b, c, point(), point()};
  const DVec3 corner[3] = {a, b, c};
  for (int j = 0; j < 3; ++j) {
    const DVec3 e0 = corner[j], e1 = corner[(j + 1) % 3];
    for (double f : {1.0 / 3, 0.5, 2.0 / 3, -1.0, 2.0})
      points.push_back({e0.x + (e1.x - e0.x) * f, e0.y + (e1.y - e0.y) * f, e0.z + (e1.z - e0.z) * f});
  }
  points.push_back({(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3, (a.z + b.z + c.z) / 3});
  const size_t exact = points.size();
  for (size_t i = 0; i < exact; ++i)
    for (double to : {-1e300, 1e300}) {
      const DVec3 q = points[i];
      points.push_back({std::nextafter(q.x, to), q.y, q.z});
      points.push_back({q.x, std::nextafter(q.y, to), std::nextafter(q.z, -to)});
    }
  for (const DVec3& p : points) RC_ASSERT(triangle_region(p, a, b, c) == prepared_triangle_region(p, prepared));
}

TEST(TriangleDistanceTree, EmptyTree) {
  ThreadPool pool(2);
  const TriangleDistanceTree tree(std::vector<float>{}, &pool);
  uint32_t hint = ~0u;
  EXPECT_TRUE(tree.empty());
  EXPECT_EQ(tree.nearest_distance_squared({0, 0, 0}, &hint), std::numeric_limits<double>::infinity());
  EXPECT_EQ(tree.nearest_or_within_squared({0, 0, 0}, 1.0, &hint), std::numeric_limits<double>::infinity());
}

}  // namespace
}  // namespace vgeo
