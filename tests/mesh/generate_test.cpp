// Properties of the procedural generators (lib/vgeo/mesh/generate.h).
#include "vgeo/mesh/generate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "generate_checks.h"
#include "support/shapes.h"
#include "vgeo/mesh/export.h"
#include "vgeo/mesh/subdivide.h"

namespace vgeo {
namespace {

using test::count_edges;
using test::mesh_hash;

const char* name(GenShape s) { return gen_shape_name(s).data(); }

TEST(GenerateShapes, NamesRoundTripAndUnknownIsRejected) {
  std::set<std::string_view> names;
  for (GenShape s : kAllGenShapes) {
    EXPECT_EQ(parse_gen_shape(gen_shape_name(s)), s);
    names.insert(gen_shape_name(s));
  }
  EXPECT_EQ(names.size(), kAllGenShapes.size());
  EXPECT_FALSE(parse_gen_shape("cube").has_value());
  EXPECT_FALSE(parse_gen_shape("").has_value());
}

// The PRNG is ours, so its stream is pinned: a change here changes every generated mesh.
TEST(GenerateShapes, SplitMix64StreamIsPinned) {
  SplitMix64 rng{0};
  EXPECT_EQ(rng.next(), 0xe220a8397b1dcdafull);  // published SplitMix64 reference value
  EXPECT_EQ(rng.next(), 0x6e789e6aa1b965f4ull);
  SplitMix64 r2{42};
  for (int i = 0; i < 1000; ++i) {
    double u = r2.uniform01();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    ASSERT_LT(r2.below(7), 7u);
  }
}

TEST(GenerateShapes, SameSeedGivesIdenticalBytesForAnyThreadCount) {
  // 100k triangles = ~50k vertices: at least two kChunk-sized work items per array.
  for (GenShape s : kAllGenShapes) {
    const uint64_t h1 = mesh_hash(test::generated_mesh(s, 100'000, 5, 1));
    EXPECT_EQ(mesh_hash(test::generated_mesh(s, 100'000, 5, 2)), h1) << name(s);
    EXPECT_EQ(mesh_hash(test::generated_mesh(s, 100'000, 5, 3)), h1) << name(s);
  }
}

TEST(GenerateShapes, GlbBytesIdenticalAcrossRunsAndThreadCounts) {
  for (GenShape s : kAllGenShapes) {
    GenerateOptions o;
    o.shape = s;
    o.target_triangles = 50'000;
    o.seed = 11;
    std::vector<uint8_t> a = encode_glb(generate_scene(o));
    o.threads = 2;
    std::vector<uint8_t> b = encode_glb(generate_scene(o));
    EXPECT_EQ(fnv1a64(a.data(), a.size()), fnv1a64(b.data(), b.size())) << name(s);
    EXPECT_EQ(a, b) << name(s);
  }
}

TEST(GenerateShapes, DifferentSeedsGiveDifferentMeshes) {
  for (GenShape s : kAllGenShapes) {
    Mesh a = test::generated_mesh(s, 20'000, 1), b = test::generated_mesh(s, 20'000, 2);
    EXPECT_NE(mesh_hash(a), mesh_hash(b)) << name(s);
    EXPECT_NE(a.positions, b.positions) << name(s);
  }
}

TEST(GenerateShapes, TriangleCountWithinDocumentedTolerance) {
  for (GenShape s : kAllGenShapes)
    // 33,075 = 12*52^2 + 12*52 + 3: the sphere's worst rounding point near the threshold.
    for (uint64_t target : {kGenToleranceFrom, uint64_t(33'075), uint64_t(54'321), uint64_t(100'000)}) {
      const double count = double(test::generated_mesh(s, target, target).triangle_count());
      EXPECT_LE(std::fabs(count - double(target)), kGenTriangleTolerance * double(target))
          << name(s) << " target " << target << " got " << count;
    }
}

TEST(GenerateShapes, TinyTargetsGiveTheShapeMinimumAndNeverFail) {
  for (GenShape s : kAllGenShapes)
    for (uint64_t target : {1, 2, 11, 100, 999}) {
      Mesh m = test::generated_mesh(s, target);
      EXPECT_GT(m.triangle_count(), 0u) << name(s) << " " << target;
      EXPECT_LE(m.triangle_count(), 2000u) << name(s) << " " << target;  // terrain min grid 16^2*2
    }
}

TEST(GenerateShapes, RejectsOutOfRangeTargetsWithStableCode) {
  for (uint64_t bad : {uint64_t(0), kMaxGenTriangles + 1}) {
    try {
      test::generated_mesh(GenShape::kSphere, bad);
      FAIL() << "accepted " << bad;
    } catch (const VgeoError& e) {
      EXPECT_EQ(e.error().code, "GEN_TRIANGLES_OUT_OF_RANGE");
      EXPECT_EQ(e.error().exit_code, kExitUsage);
    }
  }
  try {
    test::generated_mesh(GenShape::kIslands, 1000, 1, 1, uint32_t(kMaxGenTriangles / 12 + 1));
    FAIL();
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, "GEN_ISLANDS_OUT_OF_RANGE");
  }
}

TEST(GenerateShapes, ClosedShapesAreClosedOrientedManifoldsWithPositiveVolume) {
  for (GenShape s : {GenShape::kSphere, GenShape::kIslands, GenShape::kThin, GenShape::kTorus})
    for (uint64_t seed : {1, 2, 3})
      for (uint64_t target : {30, 5'000}) {
        Mesh m = test::generated_mesh(s, target, seed);
        auto e = count_edges(m);
        EXPECT_EQ(e.boundary, 0u) << name(s) << " seed " << seed << " target " << target;
        EXPECT_EQ(e.non_manifold, 0u) << name(s);
        EXPECT_EQ(e.unpaired_directed, 0u) << name(s);
        EXPECT_GT(test::signed_volume(m), 0.0) << name(s) << " seed " << seed;
        EXPECT_NO_THROW(check_loop_input(m)) << name(s);  // vertex-manifold too
      }
}

TEST(GenerateShapes, EulerCharacteristicMatchesGenus) {
  // sphere and islands: genus 0 per component (chi = 2); thin tube and torus: genus 1.
  for (GenShape s : {GenShape::kSphere, GenShape::kIslands, GenShape::kThin, GenShape::kTorus}) {
    Mesh m = test::generated_mesh(s, 8'000, 4);
    auto e = count_edges(m);
    int64_t chi = int64_t(m.vertex_count()) - int64_t(e.edges) + int64_t(m.triangle_count());
    int64_t components = int64_t(test::triangle_components(m));
    int64_t expected = (s == GenShape::kThin || s == GenShape::kTorus) ? 0 : 2 * components;
    EXPECT_EQ(chi, expected) << name(s);
  }
}

TEST(GenerateShapes, TerrainHasHolesInsideItsOpenOuterBorder) {
  for (uint64_t seed : {1, 2, 3, 4}) {
    Mesh m = test::generated_mesh(GenShape::kTerrain, 20'000, seed);
    EXPECT_NO_THROW(check_loop_input(m));  // 2-manifold with boundary (no bow-ties)
    auto e = count_edges(m);
    EXPECT_EQ(e.non_manifold, 0u);
    EXPECT_EQ(e.repeated_directed, 0u);
    size_t outer = 0, inner = 0;
    for (auto [a, b] : e.boundary_edges) {
      Vec3 pa = m.position(a), pb = m.position(b);
      auto on_border = [](Vec3 p) { return std::fabs(p.x) == 1.0f || std::fabs(p.z) == 1.0f; };
      (on_border(pa) && on_border(pb) ? outer : inner)++;
    }
    // Outer border: a square of n edges per side, fully present (holes keep off it).
    EXPECT_EQ(outer % 4, 0u);
    EXPECT_GE(outer, 4u * kTerrainMinGrid);
    EXPECT_GT(inner, 0u) << "seed " << seed << ": no hole boundary";
    EXPECT_GT(e.boundary, outer);
    EXPECT_EQ(test::triangle_components(m), 1u) << "holes must not touch the border";
  }
}

TEST(GenerateShapes, IslandsHaveTheRequestedNumberOfClosedComponents) {
  for (uint32_t k : {1u, 2u, 37u, 200u}) {
    Mesh m = test::generated_mesh(GenShape::kIslands, 30'000, k, 1, k);
    std::vector<uint32_t> comp;
    EXPECT_EQ(test::triangle_components(m, &comp), k);
    EXPECT_TRUE(test::is_closed_oriented_manifold(m));
    // Material = island index % 2: constant within each component.
    std::vector<int64_t> mat(k, -1);
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      if (mat[comp[t]] < 0) mat[comp[t]] = m.materials[t];
      ASSERT_EQ(mat[comp[t]], int64_t(m.materials[t]));
    }
  }
  // Default count: one island per kDefaultIslandTriangles.
  Mesh m = test::generated_mesh(GenShape::kIslands, 76'800, 3);
  EXPECT_EQ(test::triangle_components(m), 100u);
}

TEST(GenerateShapes, AttributesAreWellFormed) {
  for (GenShape s : kAllGenShapes) {
    Mesh m = test::generated_mesh(s, 20'000, 9);
    const size_t nv = m.vertex_count();
    ASSERT_EQ(m.normals.size(), 3 * nv) << name(s);
    ASSERT_EQ(m.uvs.size(), 2 * nv) << name(s);
    ASSERT_EQ(m.materials.size(), m.triangle_count()) << name(s);
    for (size_t v = 0; v < nv; ++v) {
      Vec3 n{m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]};
      ASSERT_NEAR(length(n), 1.0f, 1e-5f) << name(s);
      ASSERT_TRUE(m.uvs[2 * v] >= 0 && m.uvs[2 * v] <= 1 && m.uvs[2 * v + 1] >= 0 && m.uvs[2 * v + 1] <= 1);
      for (int k = 0; k < 3; ++k) ASSERT_TRUE(std::isfinite(m.positions[3 * v + k]));
    }
    std::vector<uint8_t> used(nv, 0);
    size_t mat_count[2] = {0, 0};
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      const uint32_t* i = &m.indices[3 * t];
      for (int k = 0; k < 3; ++k) {
        ASSERT_LT(i[k], nv);
        used[i[k]] = 1;
      }
      Vec3 a = m.position(i[0]), b = m.position(i[1]), c = m.position(i[2]);
      ASSERT_GT(length(cross(b - a, c - a)), 0.0f) << name(s) << ": degenerate triangle " << t;
      ASSERT_LT(m.materials[t], 2u);
      ++mat_count[m.materials[t]];
    }
    EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0) << name(s) << ": unreferenced vertices";
    EXPECT_GT(mat_count[0], 0u) << name(s);
    EXPECT_GT(mat_count[1], 0u) << name(s);
    // Smooth normals agree with the face orientation: outward on closed shapes.
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      const uint32_t* i = &m.indices[3 * t];
      Vec3 a = m.position(i[0]), b = m.position(i[1]), c = m.position(i[2]);
      Vec3 fn = cross(b - a, c - a);
      Vec3 vn{m.normals[3 * i[0]], m.normals[3 * i[0] + 1], m.normals[3 * i[0] + 2]};
      if (s != GenShape::kThin) {
        ASSERT_GT(dot(fn, vn), 0.0f) << name(s) << " triangle " << t;
      }
    }
  }
}

TEST(GenerateShapes, ThinWallIsThin) {
  Mesh m = test::generated_mesh(GenShape::kThin, 20'000, 6);
  // Inner vertex i pairs with outer vertex i (second half): radial gap = 1-3% of radius.
  const size_t half = m.vertex_count() / 2;
  for (size_t v = 0; v < half; v += 97) {
    Vec3 o = m.position(v), i = m.position(half + v);
    float ro = std::hypot(o.x, o.z), ri = std::hypot(i.x, i.z);
    EXPECT_EQ(o.y, i.y);
    EXPECT_GT(ro - ri, 0.009f * ro);
    EXPECT_LT(ro - ri, 0.031f * ro);
  }
}

TEST(GenerateShapes, ValueNoiseIsBoundedAndContinuous) {
  for (int i = 0; i < 2000; ++i) {
    float x = float(i) * 0.0137f - 7, y = float(i % 37) * 0.21f, z = -float(i % 11) * 0.3f;
    float n = value_noise(x, y, z, 99);
    ASSERT_GE(n, -1.0f);
    ASSERT_LE(n, 1.0f);
    // Lipschitz-ish: a 1e-4 step changes the value by well under 1e-2.
    ASSERT_LT(std::fabs(value_noise(x + 1e-4f, y, z, 99) - n), 1e-2f);
    ASSERT_EQ(n, value_noise(x, y, z, 99));
  }
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

// The checkers above must fire on known-bad input, or a passing test means nothing.
TEST(GenerateChecks, FireOnOpenFlippedAndNonManifoldMeshes) {
  Mesh open = test::make_grid(4);
  EXPECT_FALSE(test::is_closed_oriented_manifold(open));
  EXPECT_EQ(test::count_edges(open).boundary, 16u);

  GenerateOptions o;
  o.target_triangles = 500;
  Mesh flipped = generate_mesh(o);
  ASSERT_TRUE(test::is_closed_oriented_manifold(flipped));
  std::swap(flipped.indices[1], flipped.indices[2]);
  EXPECT_FALSE(test::is_closed_oriented_manifold(flipped));
  EXPECT_GT(test::count_edges(flipped).repeated_directed, 0u);

  Mesh all_flipped = generate_mesh(o);
  for (size_t t = 0; t < all_flipped.triangle_count(); ++t) std::swap(all_flipped.indices[3 * t + 1], all_flipped.indices[3 * t + 2]);
  EXPECT_TRUE(test::is_closed_oriented_manifold(all_flipped));
  EXPECT_LT(test::signed_volume(all_flipped), 0.0);

  Mesh fin = generate_mesh(o);  // a third triangle on an existing edge
  fin.positions.insert(fin.positions.end(), {5, 5, 5});
  fin.indices.insert(fin.indices.end(), {fin.indices[0], fin.indices[1], uint32_t(fin.vertex_count() - 1)});
  EXPECT_GT(test::count_edges(fin).non_manifold, 0u);

  // A duplicated vertex (same position, new index) must not hide a crack from the weld.
  Mesh split = generate_mesh(o);
  Vec3 p = split.position(split.indices[0]);
  split.positions.insert(split.positions.end(), {p.x, p.y, p.z});
  split.indices[0] = uint32_t(split.vertex_count() - 1);
  EXPECT_TRUE(test::is_closed_oriented_manifold(split));
  EXPECT_EQ(test::triangle_components(split), 1u);
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

// Golden GLB hashes (FNV-1a 64 of the whole file) for seed 1, 2000 triangles. They pin
// the generators, the PRNG, the noise and the GLB writer together: users compare their
// own loaders against these files, so any change here is a deliberate, announced one.
// (Also checks that optimisation level / sanitizer builds give the same bytes.)
TEST(GenerateShapes, GoldenGlbHashesArePinned) {
  struct Golden {
    const char* shape;
    uint64_t hash;
    size_t bytes;
  };
  const Golden golden[] = {
      {"sphere", 0xd5dc4878a06b7039ull, 58320}, {"terrain", 0x50e1bd99afe0f318ull, 59056},
      {"islands", 0x31fdeff77a76920dull, 56096}, {"thin", 0xcd8b05625b147616ull, 58784},
      {"torus", 0x62577b7b0f66cf63ull, 56912},
  };
  for (const Golden& g : golden) {
    GenerateOptions o;
    o.shape = *parse_gen_shape(g.shape);
    o.target_triangles = 2000;
    o.seed = 1;
    std::vector<uint8_t> glb = encode_glb(generate_scene(o));
    EXPECT_EQ(glb.size(), g.bytes) << g.shape;
    EXPECT_EQ(fnv1a64(glb.data(), glb.size()), g.hash) << g.shape;
  }
}

}  // namespace
}  // namespace vgeo
