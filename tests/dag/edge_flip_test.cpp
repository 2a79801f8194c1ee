// Edge flips (BuildOptions::edge_flips, on by default; lib/vgeo/dag/edge_flip.cpp, spec/dag.md
// Edge flips): on a noisy surface they change the DAG (flips happen), every invariant still holds
// (verify: stored error >= measured deviation, crack-free cuts, D2's corners), the output does
// not depend on the thread count; with vertex placement (the default: flipped on the placed
// surface) and without.
#include <gtest/gtest.h>

#include <cmath>

#include "support/shapes.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/verify/verify.h"

// Own namespace: test files are compiled as one unity source.
namespace vgeo::test::edge_flip {
namespace {

// A sphere with noise finer than the coarse levels' triangles: the triangulation of the kept
// vertices matters there (the case flips are for: the generated sphere of the side-by-side).
Mesh noisy_sphere() {
  Mesh m = make_sphere(40, 80);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float* p = &m.positions[3 * v];
    const double bump = 1.0 + 0.01 * std::sin(37.0 * p[0] + 3.0 * p[2]) * std::sin(41.0 * p[1] + 1.0);
    for (int k = 0; k < 3; ++k) p[k] = float(p[k] * bump);
  }
  return m;
}

std::vector<uint8_t> bytes_of(const ClusterDag& dag) {
  BuiltScene s;
  s.meshes.push_back(dag);
  return encode_dag_file(s);
}

TEST(EdgeFlips, KeepEveryInvariantAndTheThreadCountDoesNotMatter) {
  const Mesh mesh = noisy_sphere();
  for (const bool placement : {true, false}) {
    BuildOptions plain, flips;
    plain.threads = flips.threads = 1;
    plain.vertex_placement = flips.vertex_placement = placement;
    plain.edge_flips = false;
    flips.edge_flips = true;
    const ClusterDag base = build_dag(mesh, plain);
    const ClusterDag flipped = build_dag(mesh, flips);
    EXPECT_NE(bytes_of(base), bytes_of(flipped)) << "placement " << placement;  // some edge flipped
    flips.threads = 2;
    EXPECT_EQ(bytes_of(build_dag(mesh, flips)), bytes_of(flipped)) << "placement " << placement;
    VerifyOptions vo;
    vo.threads = 2;
    const VerifyReport r = verify_dag(flipped, vo);
    EXPECT_TRUE(r.ok()) << "placement " << placement << ": " << r.total_violations() << " violations, ERROR_BOUND "
                        << r.count("ERROR_BOUND");
  }
}

// A lone level's group tests its flip candidates on the pool (flip_edges_towards_leaves'
// `pool`: the gains in parallel, the flips made in the serial order): the flips must be the
// ones made without a pool. A wavy height field as leaves (unit cells) and a coarse
// triangulation of every other vertex over it, all diagonals one way: many pairs gain by a flip.
TEST(EdgeFlips, CandidatesTestedOnAPoolFlipAsWithout) {
  const int cells = 24;
  Mesh mesh;
  auto id = [&](int i, int j) { return uint32_t(i * (cells + 1) + j); };
  for (int i = 0; i <= cells; ++i)
    for (int j = 0; j <= cells; ++j)
      mesh.positions.insert(mesh.positions.end(),
                            {float(i), float(j), float(1.5 * std::sin(0.9 * i + 0.4) * std::sin(1.3 * j + 0.2))});
  build_detail::TriangleSet leaves, coarse;
  for (int i = 0; i < cells; ++i)
    for (int j = 0; j < cells; ++j) {
      leaves.corners.insert(leaves.corners.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      leaves.materials.insert(leaves.materials.end(), {0u, 0u});
    }
  for (int i = 0; i < cells; i += 2)
    for (int j = 0; j < cells; j += 2) {
      coarse.corners.insert(coarse.corners.end(), {id(i, j), id(i + 2, j), id(i + 2, j + 2), id(i, j), id(i + 2, j + 2), id(i, j + 2)});
      coarse.materials.insert(coarse.materials.end(), {0u, 0u});
    }
  ThreadPool one(1);
  const build_detail::WeldedMesh welded = build_detail::weld_positions(mesh);
  const build_detail::LeafSurface surface = build_detail::build_leaf_surface(welded, {&leaves}, one);
  const std::vector<uint8_t> locked(mesh.vertex_count(), 0);
  const float floor = 1e-6f;
  build_detail::LatticePeak peak;
  build_detail::LatticeRecord record;
  build_detail::leaf_deviation(surface, mesh, leaves, coarse, floor, &peak, &record);
  build_detail::TriangleSet serial = coarse;
  std::vector<uint8_t> serial_flipped;
  ASSERT_TRUE(build_detail::flip_edges_towards_leaves(welded, surface, locked, floor, peak, record, serial, serial_flipped));
  size_t flips = 0;
  for (uint8_t f : serial_flipped) flips += f;
  EXPECT_GE(flips, 16u) << "pairs flipped";  // more pairs than a piece's minimum on 2 threads
  for (unsigned threads : {2u, 3u}) {
    ThreadPool pool(threads);
    build_detail::TriangleSet pooled = coarse;
    std::vector<uint8_t> pooled_flipped;
    EXPECT_TRUE(build_detail::flip_edges_towards_leaves(welded, surface, locked, floor, peak, record, pooled,
                                                        pooled_flipped, nullptr, &pool));
    EXPECT_EQ(pooled.corners, serial.corners) << threads << " threads";
    EXPECT_EQ(pooled_flipped, serial_flipped) << threads << " threads";
  }
}

}  // namespace
}  // namespace vgeo::test::edge_flip
