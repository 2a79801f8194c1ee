// The builder's stored-error measurement (lib/vgeo/dag/leaf_error.cpp) takes shortcuts in *how*
// it finds the maximum (points within the floor or the running maximum of some leaf triangle,
// edges of a simplified input, corners); these properties pin that its value is bit-identical
// to the reference sampled_one_sided_distance of lib/vgeo/core to the leaves on the same
// lattice (what lib/vgeo/verify checks as ERROR_BOUND), max the floor.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "vgeo/core/surface_distance.h"
#include "vgeo/core/thread_pool.h"
#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/dag_io.h"

namespace vgeo::test {
namespace {

using build_detail::TriangleSet;

double reference_distance(const Mesh& mesh, const TriangleSet& leaves, const TriangleSet& from) {
  std::vector<float> corners;
  for (uint32_t v : leaves.corners) corners.insert(corners.end(), &mesh.positions[3 * size_t(v)], &mesh.positions[3 * size_t(v)] + 3);
  TriangleDistanceTree tree(std::move(corners));
  return sampled_one_sided_distance(mesh.positions.data(), from.corners.data(), from.triangle_count(), tree,
                                    kErrorLatticeSubdivisions);
}

uint32_t bits(float f) {
  uint32_t b;
  std::memcpy(&b, &f, 4);
  return b;
}

// `in_order`: with a peak and a record, which make the measurement search every point in
// visiting order; without them it defers its tree searches (deviation_squared: every point's
// walk first, then the largest walk bound's exact nearest), and with more than one thread it
// is cut into pieces measured on the pool (decided_deviation_squared). All must give the same
// value.
float leaf_deviation_of(const Mesh& mesh, const TriangleSet& leaves, const TriangleSet& input,
                        const TriangleSet& simplified, float floor, unsigned threads, bool in_order = false) {
  ThreadPool pool(threads);
  const build_detail::WeldedMesh welded = build_detail::weld_positions(mesh);
  const build_detail::LeafSurface surface = build_detail::build_leaf_surface(welded, {&leaves}, pool);
  build_detail::LatticePeak peak;
  build_detail::LatticeRecord record;
  return in_order ? build_detail::leaf_deviation(surface, mesh, input, simplified, floor, &peak, &record)
                  : build_detail::leaf_deviation(surface, mesh, input, simplified, floor, nullptr, nullptr, nullptr,
                                                 threads > 1 ? &pool : nullptr);
}

// A measurement with a peak and a record (the first of a group with edge flips) on a pool of
// `threads` is cut into pieces, each first measured from an assumed running maximum and measured
// again where that could have changed a decision (recorded_deviation_squared): its value, peak
// and every recorded place must be the one-thread measurement's, bit for bit. Repeated, since
// which pieces are measured again depends on how far the pieces before them had got.
bool recorded_in_pieces_as_in_one(const Mesh& mesh, const TriangleSet& leaves, const TriangleSet& input,
                                  const TriangleSet& simplified, float floor, unsigned threads) {
  ThreadPool one(1), pool(threads);
  const build_detail::WeldedMesh welded = build_detail::weld_positions(mesh);
  const build_detail::LeafSurface surface = build_detail::build_leaf_surface(welded, {&leaves}, one);
  build_detail::LatticePeak peak;
  build_detail::LatticeRecord record;
  const float value = build_detail::leaf_deviation(surface, mesh, input, simplified, floor, &peak, &record);
  for (int repeat = 0; repeat < 4; ++repeat) {
    build_detail::LatticePeak pooled_peak;
    build_detail::LatticeRecord pooled;
    const float pooled_value =
        build_detail::leaf_deviation(surface, mesh, input, simplified, floor, &pooled_peak, &pooled, nullptr, &pool);
    if (bits(pooled_value) != bits(value) || pooled_peak.triangle != peak.triangle || pooled_peak.place != peak.place ||
        pooled_peak.corner != peak.corner || pooled.places.size() != record.places.size() || !pooled.fresh.empty())
      return false;
    for (size_t k = 0; k < record.places.size(); ++k)
      if (std::memcmp(&pooled.places[k].d2, &record.places[k].d2, sizeof(double)) != 0 ||
          pooled.places[k].leaf != record.places[k].leaf)
        return false;
  }
  return true;
}

// Triangles over vertices drawn from `from` (corners of leaf triangles: both backends only
// remove vertices), or over all vertices when `from` is empty.
TriangleSet random_triangles(uint32_t vertex_count, const TriangleSet* from, uint32_t min_count, uint32_t max_count) {
  TriangleSet t;
  const uint32_t count = *rc::gen::inRange<uint32_t>(min_count, max_count);
  for (uint32_t i = 0; i < count; ++i) {
    for (int k = 0; k < 3; ++k)
      t.corners.push_back(from ? from->corners[*rc::gen::inRange<size_t>(0, from->corners.size())]
                               : *rc::gen::inRange<uint32_t>(0, vertex_count));
    t.materials.push_back(0);
  }
  return t;
}

// Positions on a grid, leaf triangles over them; the group's input and its simplification over leaf vertices. The floor is either 0
// (nothing skipped), or at least the input's own deviation (the builder's invariant: the
// members' stored errors bound their lattice points, so the input's edge points are skipped).
RC_GTEST_PROP(LeafError, BitIdenticalToReferenceLattice, ()) {
  const uint32_t vertex_count = *rc::gen::inRange<uint32_t>(3, 40);
  Mesh mesh;
  // Coarse or fine grid steps (exact floats): coarse makes coincident and collinear points
  // common, fine makes many distinct distances (each a chance for a wrong skip to show).
  const float step = *rc::gen::element(0.25f, 1.0f / 64);
  const int extent = step == 0.25f ? 4 : 64;
  for (uint32_t v = 0; v < 3 * vertex_count; ++v) mesh.positions.push_back(float(*rc::gen::inRange(-extent, extent + 1)) * step);
  const TriangleSet leaves = random_triangles(vertex_count, nullptr, 1, 60);
  const TriangleSet input = random_triangles(vertex_count, &leaves, 1, 40);
  const TriangleSet simplified = random_triangles(vertex_count, &leaves, 1, 40);
  const float input_deviation = build_detail::round_up_to_float(reference_distance(mesh, leaves, input));
  const float floor = *rc::gen::element(0.0f, input_deviation, std::nextafter(input_deviation, INFINITY),
                                        input_deviation * 2.0f + 0.25f);
  const float expected = std::max(floor, build_detail::round_up_to_float(reference_distance(mesh, leaves, simplified)));
  const unsigned threads = *rc::gen::inRange(1u, 3u);
  RC_ASSERT(bits(leaf_deviation_of(mesh, leaves, input, simplified, floor, threads)) == bits(expected));
  RC_ASSERT(bits(leaf_deviation_of(mesh, leaves, input, simplified, floor, threads, true)) == bits(expected));
}

// Many tiny leaf triangles and a few that span the whole sheet; simplified triangles far
// apart over the tiny ones' vertices (interior points off the surface): long searches, and
// the value must still be the reference's, bit for bit, for every floor.
TEST(LeafError, HugeAmongTinyTrianglesStillBitIdentical) {
  Mesh mesh;
  TriangleSet leaves, simplified;
  auto vertex = [&](float x, float y, float z) {
    mesh.positions.insert(mesh.positions.end(), {x, y, z});
    return uint32_t(mesh.vertex_count() - 1);
  };
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {  // 1600 tiny triangles on a wavy sheet
      const float x = float(i), y = float(j), z = 0.3f * float((i * 7 + j * 3) % 5);
      leaves.corners.insert(leaves.corners.end(), {vertex(x, y, z), vertex(x + 0.01f, y, z), vertex(x, y + 0.01f, z)});
      leaves.materials.push_back(0);
    }
  for (int k = 0; k < 60; ++k) {  // 60 huge ones across the sheet, at several heights
    const float z = 0.05f * float(k % 11);
    leaves.corners.insert(leaves.corners.end(), {vertex(-1, -1, z), vertex(45, -1, z + 0.5f), vertex(-1, 45, z + 1.0f)});
    leaves.materials.push_back(0);
  }
  const size_t tiny_vertices = 3 * 1600;
  for (uint32_t t = 0; t < 200; ++t) {
    const uint32_t a = (t * 97) % tiny_vertices, b = (t * 389 + 11) % tiny_vertices, c = (t * 1013 + 5) % tiny_vertices;
    simplified.corners.insert(simplified.corners.end(), {a, b, c});
    simplified.materials.push_back(0);
  }
  const float reference = build_detail::round_up_to_float(reference_distance(mesh, leaves, simplified));
  EXPECT_GT(reference, 0.0f);
  for (float floor : {0.0f, reference * 0.5f, reference, reference * 2.0f}) {
    for (unsigned threads : {1u, 2u})
      for (bool in_order : {false, true})
        EXPECT_EQ(bits(leaf_deviation_of(mesh, leaves, leaves, simplified, floor, threads, in_order)),
                  bits(std::max(floor, reference)));
    // 200 triangles: 8 to 12 recording pieces, some far beyond the others.
    for (unsigned threads : {2u, 3u, 4u})
      EXPECT_TRUE(recorded_in_pieces_as_in_one(mesh, leaves, leaves, simplified, floor, threads)) << floor << " " << threads;
  }
}

// A connected wavy sheet (a grid of cells, two triangles each, one column of vertices
// duplicated as a seam: the walk crosses it by welded position) and simplified triangles over
// its vertices, small and large: walks take real steps, some end at the sheet's border or at
// the step limit and the tree decides. Bit-identical to the reference for floors 0 and above
// the input's deviation, 1 and 2 threads.
RC_GTEST_PROP(LeafError, ConnectedSheetWithSeamBitIdentical, ()) {
  const int cells = *rc::gen::inRange(2, 24);
  const int seam = *rc::gen::inRange(0, cells + 1);  // this column's vertices get a second copy
  Mesh mesh;
  std::vector<uint32_t> left(size_t(cells + 1) * size_t(cells + 1)), right(left.size());
  for (int i = 0; i <= cells; ++i)
    for (int j = 0; j <= cells; ++j) {
      const float x = float(i), y = float(j), z = float((i * 5 + j * 3) % 7) * 0.125f;
      const size_t k = size_t(i) * size_t(cells + 1) + size_t(j);
      left[k] = right[k] = uint32_t(mesh.vertex_count());
      mesh.positions.insert(mesh.positions.end(), {x, y, z});
      if (i == seam) {
        right[k] = uint32_t(mesh.vertex_count());
        mesh.positions.insert(mesh.positions.end(), {x, y, z});
      }
    }
  auto vertex = [&](int i, int j, bool right_of_seam) {
    const size_t k = size_t(i) * size_t(cells + 1) + size_t(j);
    return right_of_seam ? right[k] : left[k];
  };
  TriangleSet leaves;
  for (int i = 0; i < cells; ++i)
    for (int j = 0; j < cells; ++j) {
      const bool r = i >= seam;  // cells right of the seam use its second copies
      leaves.corners.insert(leaves.corners.end(), {vertex(i, j, r), vertex(i + 1, j, r), vertex(i + 1, j + 1, r)});
      leaves.corners.insert(leaves.corners.end(), {vertex(i, j, r), vertex(i + 1, j + 1, r), vertex(i, j + 1, r)});
      leaves.materials.insert(leaves.materials.end(), {0u, 0u});
    }
  const TriangleSet simplified = random_triangles(uint32_t(mesh.vertex_count()), &leaves, 1, 60);
  const float reference = build_detail::round_up_to_float(reference_distance(mesh, leaves, simplified));
  const float floor = *rc::gen::element(0.0f, reference * 0.5f, reference, reference * 2.0f);
  const unsigned threads = *rc::gen::inRange(1u, 4u);
  RC_ASSERT(bits(leaf_deviation_of(mesh, leaves, leaves, simplified, floor, threads)) == bits(std::max(floor, reference)));
  RC_ASSERT(recorded_in_pieces_as_in_one(mesh, leaves, leaves, simplified, floor, threads + 1));
}

// A mesh's last levels hold fewer groups than threads; their groups run one after another,
// each measuring its error in pieces on the whole pool (run_lone_block, leaf_deviation's
// `pool`): the bytes must be the one-thread build's, with edge flips (their re-measurement
// of the flipped triangles runs in pieces) and with vertex placement (moved corners).
TEST(LeafError, LoneGroupLevelsMeasuredOnThePoolKeepTheBytes) {
  const Mesh m = generated_mesh(GenShape::kSphere, 40000);
  for (bool placement : {false, true}) {
    BuildOptions o;
    o.vertex_placement = placement;
    BuiltScene one, more;
    o.threads = 1;
    one.meshes.push_back(build_dag(m, o));
    for (unsigned threads : {2u, 3u}) {
      o.threads = threads;
      BuildReport r;
      more.meshes.assign(1, build_dag(m, o, &r));
      size_t lone = 0;  // simplified levels with fewer groups than threads
      for (size_t l = 0; l + 1 < r.levels.size(); ++l) lone += r.levels[l].groups < threads;
      EXPECT_GE(lone, 3u) << "levels that take the lone path";
      EXPECT_EQ(encode_dag_file(one), encode_dag_file(more)) << threads << " threads, placement " << placement;
    }
  }
}

}  // namespace
}  // namespace vgeo::test

namespace vgeo::test {
namespace {

// Two leaf triangles per cell of a side x side grid, the cells in a scrambled order (cell
// k * step mod side^2, step coprime to side^2), corners at(x, y); then a triangle with a
// repeated corner at (r, r) and a third triangle on an edge of cell (e, e).
template <class At>
void append_scrambled_grid(TriangleSet& leaves, uint32_t side, uint32_t step, At at, uint32_t r, uint32_t e) {
  for (uint32_t k = 0; k < side * side; ++k) {
    const uint32_t cell = (k * step) % (side * side), x = cell % side, y = cell / side;
    leaves.corners.insert(leaves.corners.end(), {at(x, y), at(x + 1, y), at(x + 1, y + 1)});
    leaves.corners.insert(leaves.corners.end(), {at(x, y), at(x + 1, y + 1), at(x, y + 1)});
  }
  leaves.corners.insert(leaves.corners.end(), {at(r, r), at(r, r), at(r + 1, r)});          // repeated corner
  leaves.corners.insert(leaves.corners.end(), {at(e, e), at(e + 1, e), at(e + 1, e + 1)});  // a third triangle on an edge
}

// The walk's adjacency (neighbour, vertex_triangle) does not depend on the pool: the counting
// sort by welded vertex in parallel parts (sort_triangles_by_vertex) lists each vertex's
// triangles as the one-pass sort does. A grid whose rows repeat their first vertex's position
// (welded copies), with triangles in a scrambled order, a repeated-corner one and a fin.
TEST(LeafSurface, AdjacencyIsTheSameOnAnyPool) {
  constexpr uint32_t kSide = 40;
  Mesh mesh;
  for (uint32_t y = 0; y <= kSide; ++y)
    for (uint32_t x = 0; x <= kSide; ++x) mesh.positions.insert(mesh.positions.end(), {float(x), float(y), 0.0f});
  for (uint32_t y = 0; y <= kSide; ++y)  // a welded copy of each row's first vertex
    mesh.positions.insert(mesh.positions.end(), {0.0f, float(y), 0.0f});
  const uint32_t copies = (kSide + 1) * (kSide + 1);
  auto at = [&](uint32_t x, uint32_t y) { return x == 0 && y % 2 ? copies + y : y * (kSide + 1) + x; };
  TriangleSet leaves;
  append_scrambled_grid(leaves, kSide, 769u, at, 3, 5);
  leaves.materials.assign(leaves.corners.size() / 3, 0);
  const build_detail::WeldedMesh welded = build_detail::weld_positions(mesh);
  ThreadPool one(1);
  const build_detail::LeafSurface serial = build_detail::build_leaf_surface(welded, {&leaves}, one);
  for (unsigned threads : {2u, 3u, 5u}) {
    ThreadPool pool(threads);
    const build_detail::LeafSurface pooled = build_detail::build_leaf_surface(welded, {&leaves}, pool);
    EXPECT_EQ(pooled.neighbour, serial.neighbour) << threads;
    EXPECT_EQ(pooled.vertex_triangle, serial.vertex_triangle) << threads;
  }
}

// LeafSurface::neighbour as it is defined: edge j of t (welded corners j, (j + 1) % 3) has as
// neighbour the first other triangle in id order with both of its ends among its welded
// corners, kNone if none. Brute force against the builder's per-vertex matching
// (link_edges_at), on a fan whose centre has more triangles than a match mask holds (40), a
// grid of 6-triangle vertices, a repeated-corner triangle, a third triangle on an edge and a
// reversed copy of a triangle.
TEST(LeafSurface, NeighbourIsTheFirstOtherTriangleWithTheEdge) {
  constexpr uint32_t kFan = 40, kSide = 6;
  Mesh mesh;
  mesh.positions = {0.0f, 0.0f, 1.0f};  // the fan's centre
  for (uint32_t i = 0; i < kFan; ++i)
    mesh.positions.insert(mesh.positions.end(), {std::cos(0.15f * float(i)), std::sin(0.15f * float(i)), 1.0f});
  const uint32_t grid = uint32_t(mesh.positions.size() / 3);
  for (uint32_t y = 0; y <= kSide; ++y)
    for (uint32_t x = 0; x <= kSide; ++x) mesh.positions.insert(mesh.positions.end(), {float(x), float(y), 0.0f});
  mesh.positions.insert(mesh.positions.end(), {0.0f, 0.0f, 0.0f});  // a welded copy of the grid's first vertex
  const uint32_t copy = uint32_t(mesh.positions.size() / 3) - 1;
  auto at = [&](uint32_t x, uint32_t y) { return x == 0 && y == 0 ? copy : grid + y * (kSide + 1) + x; };
  TriangleSet leaves;
  for (uint32_t i = 0; i < kFan; ++i) leaves.corners.insert(leaves.corners.end(), {0u, 1 + i, 1 + (i + 1) % kFan});
  append_scrambled_grid(leaves, kSide, 7u, at, 2, 4);
  leaves.corners.insert(leaves.corners.end(), {0u, 2u, 1u});  // a fan triangle reversed
  leaves.materials.assign(leaves.corners.size() / 3, 0);
  const build_detail::WeldedMesh welded = build_detail::weld_positions(mesh);
  ThreadPool one(1);
  const build_detail::LeafSurface surface = build_detail::build_leaf_surface(welded, {&leaves}, one);
  const size_t count = leaves.triangle_count();
  ASSERT_EQ(surface.neighbour.size(), 3 * count);
  auto welded_corner = [&](size_t t, int j) { return welded.weld[leaves.corners[3 * t + size_t(j)]]; };
  auto has = [&](size_t t, uint32_t w) {
    return welded_corner(t, 0) == w || welded_corner(t, 1) == w || welded_corner(t, 2) == w;
  };
  for (size_t t = 0; t < count; ++t)
    for (int j = 0; j < 3; ++j) {
      const uint32_t a = welded_corner(t, j), b = welded_corner(t, (j + 1) % 3);
      uint32_t expected = kNone;
      for (size_t other = 0; other < count && expected == kNone; ++other)
        if (other != t && has(other, a) && has(other, b)) expected = uint32_t(other);
      EXPECT_EQ(surface.neighbour[3 * t + size_t(j)], expected) << "triangle " << t << " edge " << j;
    }
}

}  // namespace
}  // namespace vgeo::test
