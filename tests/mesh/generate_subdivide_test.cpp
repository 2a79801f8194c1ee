// Loop subdivision (lib/vgeo/mesh/subdivide.h): counts, closedness, attribute carrying, and
// stable rejection of non-manifold input.
#include "support/errors.h"
#include "vgeo/mesh/subdivide.h"

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>

#include "generate_checks.h"
#include "support/shapes.h"
#include "vgeo/mesh/generate.h"

namespace vgeo {
namespace {

Mesh loop(const Mesh& m, uint32_t iterations) {
  SubdivideOptions o;
  o.iterations = iterations;
  return subdivide_loop(m, o);
}

TEST(GenerateSubdivide, MultipliesTrianglesByFourPerStepAndKeepsClosedness) {
  for (GenShape s : {GenShape::kSphere, GenShape::kIslands, GenShape::kThin, GenShape::kTorus}) {
    Mesh m = test::generated_mesh(s, 2'000, 3);
    for (uint32_t k : {1u, 2u}) {
      Mesh d = loop(m, k);
      EXPECT_EQ(d.triangle_count(), m.triangle_count() << (2 * k)) << gen_shape_name(s);
      // Euler: V' = V + E per step on a closed mesh.
      EXPECT_TRUE(test::is_closed_oriented_manifold(d)) << gen_shape_name(s) << " k=" << k;
      EXPECT_GT(test::signed_volume(d), 0.0) << gen_shape_name(s);
      EXPECT_EQ(test::triangle_components(d), test::triangle_components(m)) << gen_shape_name(s);
      EXPECT_EQ(d.normals.size(), 3 * d.vertex_count());
    }
  }
}

TEST(GenerateSubdivide, OpenBordersStayOpenAndDoubleInEdgeCount) {
  Mesh m = test::generated_mesh(GenShape::kTerrain, 3'000, 2);
  Mesh d = loop(m, 1);
  EXPECT_EQ(d.triangle_count(), 4 * m.triangle_count());
  auto before = test::count_edges(m), after = test::count_edges(d);
  EXPECT_EQ(after.boundary, 2 * before.boundary);
  EXPECT_EQ(after.non_manifold, 0u);
  EXPECT_EQ(after.repeated_directed, 0u);
}

TEST(GenerateSubdivide, SmoothsTowardsTheLimitSurface) {
  // An octahedron-like coarse cube-sphere shrinks towards its Loop limit surface, but
  // every vertex stays inside the original (convex, star-shaped) hull radius.
  Mesh m = test::make_sphere(6, 8);
  Mesh d = loop(m, 2);
  for (size_t v = 0; v < d.vertex_count(); ++v) {
    float r = length(d.position(v));
    ASSERT_LE(r, 1.0f + 1e-5f);
    ASSERT_GT(r, 0.7f);
  }
}

TEST(GenerateSubdivide, CarriesUvsAndMaterials) {
  Mesh m = test::generated_mesh(GenShape::kIslands, 3'000, 5);
  Mesh d = loop(m, 1);
  ASSERT_EQ(d.uvs.size(), 2 * d.vertex_count());
  ASSERT_EQ(d.materials.size(), d.triangle_count());
  // Old vertices come first, in order, with their UVs unchanged.
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    ASSERT_EQ(d.uvs[2 * v], m.uvs[2 * v]);
    ASSERT_EQ(d.uvs[2 * v + 1], m.uvs[2 * v + 1]);
  }
  for (float u : d.uvs) ASSERT_TRUE(u >= 0.0f && u <= 1.0f);
  // Materials are per island in the input; each island keeps its own after subdivision.
  std::vector<uint32_t> comp;
  size_t n = test::triangle_components(d, &comp);
  std::vector<int64_t> mat(n, -1);
  for (size_t t = 0; t < d.triangle_count(); ++t) {
    if (mat[comp[t]] < 0) mat[comp[t]] = d.materials[t];
    ASSERT_EQ(mat[comp[t]], int64_t(d.materials[t]));
  }
  size_t ones = std::count(d.materials.begin(), d.materials.end(), 1u);
  EXPECT_EQ(ones, 4 * size_t(std::count(m.materials.begin(), m.materials.end(), 1u)));
}

TEST(GenerateSubdivide, IsDeterministic) {
  Mesh m = test::generated_mesh(GenShape::kTorus, 2'000, 8);
  EXPECT_EQ(test::mesh_hash(loop(m, 2)), test::mesh_hash(loop(m, 2)));
}

TEST(GenerateSubdivide, HighValenceVertexIsSafe) {
  // Poles of valence 80 exceed LoopT's default weight table (50 entries).
  Mesh m = test::make_sphere(5, 80);
  Mesh d = loop(m, 1);
  EXPECT_EQ(d.triangle_count(), 4 * m.triangle_count());
  EXPECT_TRUE(test::is_closed_oriented_manifold(d));
  for (float p : d.positions) ASSERT_TRUE(std::isfinite(p));
}

TEST(GenerateSubdivide, DropsUnreferencedVertices) {
  Mesh m = test::make_sphere(4, 6);
  m.positions.insert(m.positions.end(), {9, 9, 9});
  m.uvs.clear();
  Mesh d = loop(m, 1);
  for (float p : d.positions) ASSERT_NE(p, 9.0f);
  EXPECT_TRUE(d.uvs.empty());
  EXPECT_TRUE(d.materials.empty());
}

TEST(GenerateSubdivide, RejectsBadInputWithStableCodes) {
  Mesh tri;
  tri.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
  // Three triangles on edge (0,1): a fin.
  tri.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  EXPECT_EQ(test::error_code_of([&] { loop(tri, 1); }), "SUBDIVIDE_NON_MANIFOLD");
  // Two triangles touching only at vertex 0: a bow-tie.
  tri.indices = {0, 1, 2, 0, 3, 4};
  EXPECT_EQ(test::error_code_of([&] { loop(tri, 1); }), "SUBDIVIDE_NON_MANIFOLD");
  // Same edge direction twice: inconsistent orientation.
  tri.indices = {0, 1, 2, 0, 1, 3};
  EXPECT_EQ(test::error_code_of([&] { loop(tri, 1); }), "SUBDIVIDE_NON_MANIFOLD");
  tri.indices = {0, 1, 1};
  EXPECT_EQ(test::error_code_of([&] { loop(tri, 1); }), "SUBDIVIDE_DEGENERATE_TRIANGLE");
  tri.indices = {0, 1, 7};
  EXPECT_EQ(test::error_code_of([&] { loop(tri, 1); }), "SUBDIVIDE_INDEX_OUT_OF_RANGE");
  tri.indices.clear();
  EXPECT_EQ(test::error_code_of([&] { loop(tri, 1); }), "SUBDIVIDE_EMPTY");
  Mesh big = test::make_sphere(4, 6);
  SubdivideOptions o;
  o.iterations = 3;
  o.max_triangles = 64 * big.triangle_count() - 1;
  EXPECT_EQ(test::error_code_of([&] { subdivide_loop(big, o); }), "SUBDIVIDE_TOO_LARGE");
  // Legal: two triangles sharing an edge (open strip) and a lone triangle.
  tri.indices = {0, 1, 2, 1, 0, 3};
  EXPECT_EQ(loop(tri, 2).triangle_count(), 32u);
  tri.indices = {0, 1, 2};
  EXPECT_EQ(loop(tri, 1).triangle_count(), 4u);
}

// Random small soups on a 3x3x3 integer lattice: coincident vertices, fins, bow-ties and
// flips are common. Either a stable SUBDIVIDE_* rejection or an exact x4 result.
RC_GTEST_PROP(GenerateSubdivide, RandomSoupsAreRejectedOrQuadrupled, ()) {
  const int nv = *rc::gen::inRange(3, 12);
  const int nt = *rc::gen::inRange(1, 14);
  Mesh m;
  for (int v = 0; v < nv; ++v)
    for (int k = 0; k < 3; ++k) m.positions.push_back(float(*rc::gen::inRange(0, 3)));
  for (int i = 0; i < 3 * nt; ++i) m.indices.push_back(uint32_t(*rc::gen::inRange(0, nv)));
  try {
    Mesh d = loop(m, 1);
    RC_ASSERT(d.triangle_count() == 4 * m.triangle_count());
    auto e = test::count_edges(d);
    (void)e;
  } catch (const VgeoError& e) {
    RC_ASSERT(e.error().code.rfind("SUBDIVIDE_", 0) == 0);
    RC_ASSERT(e.error().code != "SUBDIVIDE_INTERNAL");
  }
}

}  // namespace
}  // namespace vgeo
