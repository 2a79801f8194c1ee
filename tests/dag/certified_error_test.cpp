// Certified mode (BuildOptions::error_bound = ErrorBound::kCertified; lib/vgeo/dag/leaf_certify.cpp,
// spec/dag.md §Error "Certified bound"): the same clusters as the default build, stored errors
// at least the default's and at least the deviation on a dense (16-step) lattice, which finds
// points between the 3-step lattice's; verify's independent certification (certified_bound,
// ERROR_CERTIFIED) proves them, and fires on stored errors lowered to the 3-step maximum.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "support/shapes.h"
#include "vgeo/core/surface_distance.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/verify/verify.h"

// Own namespace: test files are compiled as one unity source.
namespace vgeo::test::certified_error {
namespace {

using build_detail::TriangleSet;

// A lattice far denser than the builder's and verify's default (3): between those points the
// continuous deviation is up to 1.3x larger on the CGAL meshes (docs/acceptance/issue23_certfast.md).
constexpr uint32_t kDenseLattice = 16;
// The builder's slack (leaf_certify.cpp kCertifySlack) and depth cap: the certified value is
// at most max(floor, (lattice max + longest edge) × (1 + slack)), the Lipschitz bound of the
// whole triangle; 1e-6 relative covers the rounding of the lattice points.
constexpr double kCertifySlack = 1.0 / 128;
constexpr double kRounding = 1e-6;
constexpr double kLatticePointRounding = 1e-12;

// Smooth but not trivially flat shapes, small enough for ASan: a sphere with bumps steeper
// than the coarse triangles (the case where the overlay splits), and a wavy open sheet with a
// hole (open borders simplify; the overlay meets borders).
Mesh bumpy_sphere() {
  Mesh m = make_sphere(24, 48);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float* p = &m.positions[3 * v];
    const double bump = 1.0 + 0.03 * std::sin(9.0 * p[0]) * std::sin(7.0 * p[1] + 1.0) * std::cos(5.0 * p[2]);
    for (int k = 0; k < 3; ++k) p[k] = float(p[k] * bump);
  }
  return m;
}

Mesh wavy_sheet_with_hole() {
  Mesh m = make_grid(40, 1.0f, true);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float* p = &m.positions[3 * v];
    p[2] = float(0.04 * std::sin(6.0 * p[0]) * std::cos(5.0 * p[1]));
  }
  return m;
}

std::vector<uint8_t> bytes_of(const ClusterDag& dag) {
  BuiltScene s;
  s.meshes.push_back(dag);
  return encode_dag_file(s);
}

// The DAG with every stored error zeroed: what the structure is, errors aside.
std::vector<uint8_t> structure_bytes(ClusterDag dag) {
  for (DagCluster& k : dag.clusters) k.lod_error = 0, k.parent_error = 0;
  for (DagGroup& g : dag.groups) g.parent_error = 0;
  for (BvhNode& n : dag.bvh_nodes) n.max_parent_error = 0;
  return bytes_of(dag);
}

double longest_edge(const ClusterDag& dag, const DagCluster& k) {
  double e = 0;
  for (uint32_t t = 0; t < k.triangle_count; ++t)
    for (int j = 0; j < 3; ++j) {
      const float* a = &dag.positions[3 * (size_t(k.vertex_offset) + dag.indices[3 * (size_t(k.triangle_offset) + t) + size_t(j)])];
      const float* b = &dag.positions[3 * (size_t(k.vertex_offset) + dag.indices[3 * (size_t(k.triangle_offset) + t) + size_t((j + 1) % 3)])];
      e = std::max(e, std::sqrt(double(a[0] - b[0]) * (a[0] - b[0]) + double(a[1] - b[1]) * (a[1] - b[1]) +
                                double(a[2] - b[2]) * (a[2] - b[2])));
    }
  return e;
}

TEST(CertifiedError, SameClustersLargerErrorsBoundDenseLattice) {
  for (const Mesh& mesh : {bumpy_sphere(), wavy_sheet_with_hole()}) {
    BuildOptions measured;
    measured.threads = 2;
    BuildOptions certified = measured;
    certified.error_bound = ErrorBound::kCertified;
    const ClusterDag a = build_dag(mesh, measured);
    const ClusterDag b = build_dag(mesh, certified);
    // The same clusters: everything but the stored errors is identical.
    ASSERT_EQ(a.clusters.size(), b.clusters.size()) << mesh.name;
    EXPECT_TRUE(structure_bytes(a) == structure_bytes(b)) << mesh.name;
    // Deterministic: the same bytes with one thread.
    certified.threads = 1;
    EXPECT_TRUE(bytes_of(build_dag(mesh, certified)) == bytes_of(b)) << mesh.name;
    VerifyOptions dense_options;
    dense_options.error_samples_per_edge = kDenseLattice;
    dense_options.threads = 2;
    const ClusterDeviation dense = measure_cluster_deviation(b, dense_options);
    size_t raised = 0;
    for (size_t c = 0; c < b.clusters.size(); ++c) {
      const DagCluster& k = b.clusters[c];
      if (k.generating_group == kNone) continue;
      EXPECT_GE(k.lod_error, a.clusters[c].lod_error) << mesh.name << " cluster " << c;
      EXPECT_GE(double(k.lod_error), dense.distance[c]) << mesh.name << " cluster " << c;
      raised += k.lod_error > a.clusters[c].lod_error;
    }
    // The 3-step maximum understates the continuous one somewhere on these shapes.
    EXPECT_GT(raised, 0u) << mesh.name;
    // Not loose: a group's stored error is at most its members' or the Lipschitz bound of its
    // generated triangles from the dense lattice's maximum (each point is within a cell's
    // covering radius, ≤ longest edge / 16, of a dense lattice point), with the slack.
    for (const DagGroup& g : b.groups) {
      if (g.generated_count == 0) continue;
      double members = 0, deviation = 0, longest = 0;
      for (uint32_t c = g.first_cluster; c < g.first_cluster + g.cluster_count; ++c)
        members = std::max(members, double(b.clusters[c].lod_error));
      for (uint32_t i = 0; i < g.generated_count; ++i) {
        const uint32_t c = b.generated_clusters[g.first_generated + i];
        deviation = std::max(deviation, dense.distance[c]);
        longest = std::max(longest, longest_edge(b, b.clusters[c]));
      }
      EXPECT_LE(double(g.parent_error),
                std::max(members, (deviation + longest / kDenseLattice) * (1 + kCertifySlack)) * (1 + kRounding) +
                    longest / 64)  // the depth cap's sub-triangles (4^-6 of the area, 1/64 across)
          << mesh.name;
    }
    VerifyOptions vo;
    vo.checks = kCheckErrorBound | kCheckCertifiedBound;
    vo.threads = 2;
    const VerifyReport r = verify_dag(b, vo);
    EXPECT_TRUE(r.ok()) << mesh.name << " ERROR_CERTIFIED " << r.count("ERROR_CERTIFIED");
  }
}

// The check is independent of the builder: stored errors lowered to the 3-step maximum
// (rounded up, as the default build stores them) pass ERROR_BOUND, and every cluster with a
// dense-lattice point beyond the check's threshold (stored + 4 float ulps of the largest
// coordinate) is reported — such a point is one no sound proof can cover.
TEST(CertifiedError, CheckFiresOnErrorsLoweredToTheSampledMaximum) {
  BuildOptions bo;
  bo.threads = 2;
  bo.error_bound = ErrorBound::kCertified;
  ClusterDag dag = build_dag(bumpy_sphere(), bo);
  VerifyOptions vo;
  vo.checks = kCheckErrorBound | kCheckCertifiedBound;
  vo.threads = 2;
  vo.max_stored_per_code = uint32_t(dag.clusters.size());
  const ClusterDeviation sparse = measure_cluster_deviation(dag, vo);
  VerifyOptions dense_options = vo;
  dense_options.error_samples_per_edge = kDenseLattice;
  const ClusterDeviation dense = measure_cluster_deviation(dag, dense_options);
  double max_abs = 0;
  for (float p : dag.positions) max_abs = std::max(max_abs, std::fabs(double(p)));
  const float m = float(max_abs);
  const double tolerance = 4.0 * (double(std::nextafter(m, std::numeric_limits<float>::infinity())) - double(m));
  std::vector<uint8_t> expect(dag.clusters.size(), 0);
  size_t planted = 0;
  for (size_t c = 0; c < dag.clusters.size(); ++c) {
    DagCluster& k = dag.clusters[c];
    if (k.generating_group == kNone) continue;
    k.lod_error = build_detail::round_up_to_float(sparse.distance[c]);
    if (dense.distance[c] > double(k.lod_error) + tolerance) expect[c] = 1, ++planted;
  }
  ASSERT_GT(planted, 0u);
  const VerifyReport r = verify_dag(dag, vo);
  EXPECT_EQ(r.count("ERROR_BOUND"), 0u);
  std::vector<uint8_t> fired(dag.clusters.size(), 0);
  for (const Violation& v : r.violations)
    if (v.code == "ERROR_CERTIFIED") {
      fired[v.index] = 1;
      EXPECT_EQ(v.check, "certified_bound");
    }
  for (size_t c = 0; c < dag.clusters.size(); ++c)
    if (expect[c]) {
      EXPECT_TRUE(fired[c]) << "cluster " << c << " stored " << dag.clusters[c].lod_error << " dense " << dense.distance[c];
    }
  // Not requested, not run: kCheckAll leaves it out (the default build does not promise it).
  VerifyOptions all;
  all.threads = 2;
  all.views = 4;
  EXPECT_EQ(verify_dag(dag, all).count("ERROR_CERTIFIED"), 0u);
}

// ---- certified_leaf_deviation on random inputs ----

double reference_distance(const Mesh& mesh, const TriangleSet& leaves, const TriangleSet& from, uint32_t subdivisions) {
  std::vector<float> corners;
  for (uint32_t v : leaves.corners) corners.insert(corners.end(), &mesh.positions[3 * size_t(v)], &mesh.positions[3 * size_t(v)] + 3);
  TriangleDistanceTree tree(std::move(corners));
  return sampled_one_sided_distance(mesh.positions.data(), from.corners.data(), from.triangle_count(), tree, subdivisions);
}

double longest_edge(const Mesh& mesh, const TriangleSet& t) {
  double e = 0;
  for (size_t i = 0; i < t.triangle_count(); ++i)
    for (int j = 0; j < 3; ++j) {
      const float* a = &mesh.positions[3 * size_t(t.corners[3 * i + j])];
      const float* b = &mesh.positions[3 * size_t(t.corners[3 * i + (j + 1) % 3])];
      e = std::max(e, std::sqrt(double(a[0] - b[0]) * (a[0] - b[0]) + double(a[1] - b[1]) * (a[1] - b[1]) +
                                double(a[2] - b[2]) * (a[2] - b[2])));
    }
  return e;
}

uint32_t bits(float f) {
  uint32_t b;
  std::memcpy(&b, &f, 4);
  return b;
}

float certified_of(const Mesh& mesh, const TriangleSet& leaves, const TriangleSet& simplified, float floor, double lower,
                   unsigned threads) {
  ThreadPool pool(threads);
  const build_detail::WeldedMesh welded = build_detail::weld_positions(mesh);
  const build_detail::LeafSurface surface = build_detail::build_leaf_surface(welded, {&leaves}, pool);
  const build_detail::LeafTwins twins = build_detail::build_leaf_twins(surface, welded, pool);
  return build_detail::certified_leaf_deviation(surface, twins, mesh, {&simplified}, floor, lower);
}

// A connected wavy sheet (a grid of cells, two triangles each; one column of vertices
// duplicated as a seam the adjacency crosses by welded position) and simplified triangles over
// its vertices, small and large. For floors 0 and around the lattice maximum, with and
// without that maximum as the starting point: at least the 3-step and the 16-step lattice
// maxima (a flood or bound that accepted too little would fall below them) and the floor, at
// most the Lipschitz bound of the whole triangles with the slack, the same bits with 1 and 2
// threads building the tree.
RC_GTEST_PROP(CertifiedError, SheetWithSeamBoundsDenseLattice, ()) {
  const int cells = *rc::gen::inRange(2, 16);
  const int seam = *rc::gen::inRange(0, cells + 1);
  Mesh mesh;
  const double amplitude = *rc::gen::element(0.0, 0.05, 0.3);
  auto add = [&](int x, int y) {
    const double u = double(x) / cells, v = double(y) / cells;
    mesh.positions.insert(mesh.positions.end(),
                          {float(u), float(v), float(amplitude * std::sin(7.0 * u + 1.0) * std::cos(5.0 * v))});
    return uint32_t(mesh.vertex_count() - 1);
  };
  std::vector<uint32_t> id((cells + 1) * (cells + 1)), twin_id((cells + 1) * (cells + 1));
  for (int y = 0; y <= cells; ++y)
    for (int x = 0; x <= cells; ++x) {
      id[size_t(y * (cells + 1) + x)] = add(x, y);
      twin_id[size_t(y * (cells + 1) + x)] = x == seam ? add(x, y) : id[size_t(y * (cells + 1) + x)];
    }
  TriangleSet leaves;
  for (int y = 0; y < cells; ++y)
    for (int x = 0; x < cells; ++x) {
      // Cells right of the seam use its duplicate vertices.
      auto at = [&](int cx, int cy) { return cx == seam && x >= seam ? twin_id[size_t(cy * (cells + 1) + cx)] : id[size_t(cy * (cells + 1) + cx)]; };
      leaves.corners.insert(leaves.corners.end(), {at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y), at(x + 1, y + 1), at(x, y + 1)});
      leaves.materials.insert(leaves.materials.end(), {0, 0});
    }
  TriangleSet simplified;
  const uint32_t count = *rc::gen::inRange<uint32_t>(1, 12);
  for (uint32_t i = 0; i < count; ++i) {
    for (int k = 0; k < 3; ++k) simplified.corners.push_back(leaves.corners[*rc::gen::inRange<size_t>(0, leaves.corners.size())]);
    simplified.materials.push_back(0);
  }
  const double sparse = reference_distance(mesh, leaves, simplified, kErrorLatticeSubdivisions);
  const double dense = reference_distance(mesh, leaves, simplified, kDenseLattice);
  const float sampled = build_detail::round_up_to_float(sparse);
  const float floor = *rc::gen::element(0.0f, sampled * 0.5f, sampled, sampled * 2.0f);
  const double lower = *rc::gen::element(0.0, sparse);
  const float one = certified_of(mesh, leaves, simplified, floor, lower, 1);
  // A lattice point is rounded in double (~1e-16 of the unit coordinates here) and may lie that
  // far off a flat sheet: an absolute 1e-12 (far below the float ulps verify's threshold adds).
  RC_ASSERT(double(one) >= dense - kLatticePointRounding);
  RC_ASSERT(double(one) >= sparse - kLatticePointRounding);
  RC_ASSERT(one >= std::max(floor, build_detail::round_up_to_float(lower)));  // the build's: never below its measured value
  RC_ASSERT(double(one) <= std::max(double(floor), (sparse + longest_edge(mesh, simplified)) * (1 + kCertifySlack) * (1 + kRounding)));
  RC_ASSERT(bits(certified_of(mesh, leaves, simplified, floor, lower, 2)) == bits(one));
}

}  // namespace
}  // namespace vgeo::test::certified_error
