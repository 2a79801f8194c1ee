// Property: a decoded DAG passes every lib/vgeo/verify check (default options) whenever the
// source DAG did — the stored bounds and errors carry the quantization slack of
// spec/format.md §2.1, so quantized vertices stay inside the stored spheres and the
// quantized surfaces stay within the stored LOD errors on verify's sampling lattice.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "format_test_util.h"
#include "vgeo/dag/build.h"
#include "vgeo/format/format.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/verify/verify.h"

namespace vgeo {
namespace {

std::string first_violations(const VerifyReport& r) {
  std::string s;
  for (const ViolationCount& c : r.counts) s += c.code + " x" + std::to_string(c.count) + "; ";
  for (size_t i = 0; i < r.violations.size() && i < 3; ++i) s += r.violations[i].message + "; ";
  return s;
}

struct Case {
  const char* name;
  Mesh mesh;
};

std::vector<Case> cases() {
  GenerateOptions g;
  g.shape = GenShape::kTorus;
  g.target_triangles = 6000;
  g.seed = 7;
  return {{"sphere", test::make_sphere(32, 64)},
          {"grid_with_hole", test::make_grid(40, 2.0f, true)},
          {"generated_torus", generate_mesh(g)},
          // Two sheets one ulp apart along a seam: the grid welds what the build keeps apart, so
          // a seam the simplifier moved on one side only would be a crack (spec/dag.md Seams).
          {"ulp_seam_sphere", test::make_ulp_seam(test::make_sphere(32, 64))}};
}

// position_bits 16 is the default grid; 8 bits is a coarse grid whose slack dominates the
// builder's own errors, so a missing or too small adjustment is caught.
void check_decoded_dags_verify(Simplifier simplifier) {
  for (const Case& c : cases()) {
    BuildOptions bo;
    bo.threads = 1;
    bo.simplifier = simplifier;
    const ClusterDag dag = build_dag(c.mesh, bo);
    VerifyOptions vo;
    vo.threads = 1;
    const VerifyReport source = verify_dag(dag, vo);
    ASSERT_TRUE(source.ok()) << c.name << ": source DAG fails verify: " << first_violations(source);
    ASSERT_GT(dag.level_count, 1u) << c.name;
    for (uint32_t bits : {16u, 8u}) {
      FormatOptions o;
      o.position_bits = bits;
      o.zstd_level = 1;
      const std::vector<uint8_t> file = encode_format(test::scene_of({dag}), o);
      const BuiltScene decoded = decode_format(file.data(), file.size(), "<test>");
      const VerifyReport r = verify_dag(decoded.meshes[0], vo);
      EXPECT_TRUE(r.ok()) << c.name << ", " << bits << "-bit grid: " << first_violations(r);
    }
  }
}

TEST(FormatVerify, DecodedDagPassesVerifyMeshopt) { check_decoded_dags_verify(Simplifier::kMeshopt); }
TEST(FormatVerify, DecodedDagPassesVerifyOpenMesh) { check_decoded_dags_verify(Simplifier::kOpenMesh); }

// The slack function keeps shared values bit-identical and relations monotone.
TEST(FormatVerify, SlackIsMonotoneAndKeepsSpecialValues) {
  ClusterDag d;
  d.clusters.resize(2);
  d.clusters[0].generating_group = kNone;
  d.clusters[0].lod_error = 0.0f;
  d.clusters[0].parent_error = 0.25f;
  d.clusters[1].generating_group = 0;
  d.clusters[1].lod_error = 0.25f;
  d.clusters[1].parent_error = std::numeric_limits<float>::infinity();
  d.clusters[0].bounds = {{1, 2, 3}, 0.5f};
  d.clusters[1].bounds = {{1, 2, 3}, -1.0f};
  d.bounds.extend(Vec3{-1.3f, 0.1f, 2.0f});
  d.bounds.extend(Vec3{1.3f, 0.9f, 2.0f});
  inflate_metadata_for_quantization(&d, -4);
  const double step = 1.0 / 16;
  EXPECT_EQ(d.clusters[0].lod_error, 0.0f);
  EXPECT_EQ(d.clusters[0].parent_error, d.clusters[1].lod_error);
  EXPECT_GE(double(d.clusters[0].parent_error), 0.25 + std::sqrt(3.0) * step);
  EXPECT_TRUE(std::isinf(d.clusters[1].parent_error));
  EXPECT_GE(double(d.clusters[0].bounds.radius), 0.5 + std::sqrt(3.0) / 2 * step);
  EXPECT_EQ(d.clusters[1].bounds.radius, -1.0f);
  EXPECT_EQ(d.bounds.min.x, -1.3125f);  // floor(-20.8) = -21 steps
  EXPECT_EQ(d.bounds.max.x, 1.3125f);  // ceil(20.8) = 21 steps
  EXPECT_EQ(d.bounds.min.z, 2.0f);
  EXPECT_EQ(d.bounds.max.z, 2.0f);
}

}  // namespace
}  // namespace vgeo
