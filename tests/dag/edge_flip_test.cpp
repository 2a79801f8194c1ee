// Edge flips (BuildOptions::edge_flips, on by default; lib/vgeo/dag/edge_flip.cpp, spec/dag.md
// Edge flips): on a noisy surface they change the DAG (flips happen), every invariant still holds
// (verify: stored error >= measured deviation, crack-free cuts, D2's corners), the output does
// not depend on the thread count; with vertex placement (the default: flipped on the placed
// surface) and without.
#include <gtest/gtest.h>

#include <cmath>

#include "support/shapes.h"
#include "vgeo/dag/build.h"
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

}  // namespace
}  // namespace vgeo::test::edge_flip
