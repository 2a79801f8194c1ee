// lib/vgeo/verify on hand-built DAGs: the valid DAG passes every check, and each deliberate
// corruption is caught with its stable code (spec/invariants.md).
#include <gtest/gtest.h>

#include <cstdio>
#include <set>

#include <nlohmann/json.hpp>

#include "hand_dag.h"
#include "vgeo/verify/verify.h"

namespace vgeo {
namespace {

using test::make_hand_dag;

VerifyOptions quick_options() {
  VerifyOptions o;
  o.views = 96;
  o.thresholds_per_view = 4;
  o.threads = 2;
  return o;
}

::testing::AssertionResult passes(const VerifyReport& r) {
  if (r.ok()) return ::testing::AssertionSuccess();
  auto f = ::testing::AssertionFailure() << verify_report_summary(r);
  for (size_t i = 0; i < r.violations.size() && i < 10; ++i)
    f << r.violations[i].code << ": " << r.violations[i].element << " " << r.violations[i].index << ": "
      << r.violations[i].message << "\n";
  return f;
}

std::vector<uint32_t> range(uint32_t a, uint32_t b) {
  std::vector<uint32_t> v;
  for (uint32_t i = a; i < b; ++i) v.push_back(i);
  return v;
}
std::vector<uint32_t> concat(std::vector<uint32_t> a, const std::vector<uint32_t>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

TEST(Verify, HandDagPassesEveryCheck) {
  ClusterDag dag = make_hand_dag();
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_TRUE(passes(r));
  EXPECT_EQ(r.checks.size(), 5u);
  EXPECT_EQ(r.leaf_clusters, 16u);
  EXPECT_EQ(r.cuts_tested, 96u * 4u);
  // The cuts are not all the same: some select leaves, some coarser levels.
  EXPECT_LT(r.cut_clusters.min, r.cut_clusters.max);
  // Measured error: level-1 fans deviate by kLevel1Height of stored kLevel1Error, etc.
  ASSERT_EQ(r.error_ratio.count, 10u);
  EXPECT_NEAR(r.error_ratio.min, test::kLevel1Height / test::kLevel1Error, 1e-6);
  EXPECT_NEAR(r.error_ratio.max, test::kLevel2Height / test::kLevel2Error, 1e-6);
}

// An untrusted DAG may claim any level count; the checker's memory must follow what the file
// holds (fuzz_dag_verify found an out-of-memory abort sizing per-level rows by level_count).
TEST(Verify, ClaimedLevelCountDoesNotSizeAllocations) {
  ClusterDag dag = make_hand_dag();
  dag.level_count = 0xFFFFFFFFu;
  VerifyOptions o = quick_options();
  o.views = 4;
  VerifyReport r;
  ASSERT_NO_THROW(r = verify_dag(dag, o));
  EXPECT_FALSE(r.ok());
  EXPECT_LE(r.error_ratio_per_level.size(), 3u);
}

TEST(Verify, HandDagFarFromOriginAndTinyPasses) {
  EXPECT_TRUE(passes(verify_dag(make_hand_dag({{1e6f, -2e6f, 5e5f}, 1.0f}), quick_options())));
  EXPECT_TRUE(passes(verify_dag(make_hand_dag({{0, 0, 0}, 1e-4f}), quick_options())));
}

TEST(Verify, ExplicitCutsOfHandDag) {
  ClusterDag dag = make_hand_dag();
  CutCheckContext ctx = prepare_cut_check(dag);
  ASSERT_TRUE(ctx.usable);
  EXPECT_EQ(ctx.leaf_open_edges.size(), 32u);  // the square's border
  EXPECT_TRUE(check_cut(dag, ctx, range(0, 16)).ok());                       // leaves
  EXPECT_TRUE(check_cut(dag, ctx, range(16, 24)).ok());                      // level 1
  EXPECT_TRUE(check_cut(dag, ctx, range(24, 26)).ok());                      // root
  EXPECT_TRUE(check_cut(dag, ctx, concat({16, 17}, range(4, 16))).ok());     // quadrant 0 coarse
  EXPECT_TRUE(check_cut(dag, ctx, concat(range(0, 8), range(20, 24))).ok()); // quadrants 2, 3 coarse
}

TEST(Verify, CutSelectingClusterTwiceIsCaught) {
  ClusterDag dag = make_hand_dag();
  // A leaf and the cluster generated from its group: leaves of quadrant 0 covered twice.
  CutCheck both = check_cut(dag, concat(range(0, 16), {16}));
  EXPECT_FALSE(both.ok());
  ASSERT_FALSE(both.violations.empty());
  EXPECT_EQ(both.violations[0].code, "CUT_COVERAGE");
  // The same index twice.
  CutCheck dup = check_cut(dag, concat(range(0, 16), {3}));
  bool saw_dup = false, saw_cov = false;
  for (const auto& c : dup.counts) saw_dup |= c.code == "CUT_DUPLICATE", saw_cov |= c.code == "CUT_COVERAGE";
  EXPECT_TRUE(saw_dup);
  EXPECT_TRUE(saw_cov);
  // Missing leaves: a hole (coverage 0) and open edges.
  CutCheck hole = check_cut(dag, range(1, 16));
  bool saw_crack = false;
  for (const auto& c : hole.counts) saw_cov |= c.code == "CUT_COVERAGE", saw_crack |= c.code == "CRACK_OPEN_EDGE";
  EXPECT_TRUE(saw_crack);
  // Only half of quadrant 0's level-1 pair: coverage fails (the sibling rule).
  EXPECT_FALSE(check_cut(dag, concat({16}, range(4, 16))).ok());
  CutCheck dangling = check_cut(dag, {999});
  ASSERT_FALSE(dangling.violations.empty());
  EXPECT_EQ(dangling.violations[0].code, "CUT_DANGLING_INDEX");
}

TEST(Verify, LoweredParentErrorIsCaught) {
  ClusterDag dag = make_hand_dag();
  test::set_group_parent_error(dag, 4, 0.01f);  // below its members' lod_error 0.03
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.count("MONO_ERROR"), 8u);
  EXPECT_GT(r.count("MONO_PROJECTED"), 0u);
  EXPECT_EQ(r.count("ERROR_BOUND"), 2u);  // the root's measured 0.05 > stored 0.01
  EXPECT_EQ(r.count("STRUCT_SHARED_VALUE"), 0u);
}

// The per-cluster projected check on its own (not only along DAG edges): group 4's members
// project more lod error than their own (lowered) parent error from every eye.
TEST(Verify, ClusterProjectingMoreThanItsOwnParentIsCaught) {
  ClusterDag dag = make_hand_dag();
  test::set_group_parent_error(dag, 4, 0.01f);  // below its members' lod_error 0.03
  VerifyReport r = verify_dag(dag, quick_options());
  bool within_cluster = false;
  for (const auto& v : r.violations)
    within_cluster |= v.code == "MONO_PROJECTED" && v.message.find("> projected parent_error") != std::string::npos;
  EXPECT_TRUE(within_cluster);
}

TEST(Verify, ShrunkParentSphereIsCaught) {
  ClusterDag dag = make_hand_dag();
  // Group 4's members have non-zero lod_error, so a smaller parent sphere lets a child
  // project more error than its parent from eyes near the child.
  Sphere s = dag.groups[4].parent_bounds;
  s.radius *= 0.5f;
  test::set_group_parent_bounds(dag, 4, s);
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_FALSE(r.ok());
  EXPECT_GT(r.count("MONO_BOUNDS"), 0u);
  EXPECT_GT(r.count("MONO_PROJECTED"), 0u);
}

TEST(Verify, RemovedTriangleIsCaught) {
  ClusterDag dag = make_hand_dag();
  dag.clusters[16].triangle_count -= 1;  // a level-1 fan loses its last triangle
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_FALSE(r.ok());
  EXPECT_GT(r.count("CRACK_OPEN_EDGE"), 0u);
  CutCheck c = check_cut(dag, range(16, 24));
  EXPECT_FALSE(c.ok());
  ASSERT_FALSE(c.violations.empty());
  EXPECT_EQ(c.violations[0].code, "CRACK_OPEN_EDGE");
}

TEST(Verify, CrackLinesNameTheEdge) {
  // Each CRACK_OPEN_EDGE line names its edge (welded ids and positions of both ends), so the
  // lines of one cut never read as duplicates without --json.
  ClusterDag dag = make_hand_dag();
  dag.clusters[16].triangle_count -= 1;
  CutCheck c = check_cut(dag, range(16, 24));
  ASSERT_GE(c.violations.size(), 2u);
  std::set<std::string> messages;
  for (const Violation& v : c.violations) {
    ASSERT_EQ(v.code, "CRACK_OPEN_EDGE");
    const std::string& m = v.message;
    EXPECT_EQ(m.rfind("edge v", 0), 0u) << m;
    ASSERT_EQ(v.values.size(), 6u) << m;
    // Both ends' coordinates are in the line, as %.9g of the stored floats.
    for (const VerifyValue& value : v.values) {
      char coordinate[64];
      std::snprintf(coordinate, sizeof coordinate, "%.9g", value.value);
      EXPECT_NE(m.find(coordinate), std::string::npos) << value.name << " " << m;
    }
    messages.insert(m);
  }
  EXPECT_EQ(messages.size(), c.violations.size());
}

TEST(Verify, MovedBorderVertexInGeneratedClusterIsCaught) {
  ClusterDag dag = make_hand_dag();
  // Cluster 16 (quadrant 0's first fan half) stores border vertex (4, 1) shared with quadrant 1.
  const DagCluster& k = dag.clusters[16];
  bool moved = false;
  for (uint32_t v = 0; v < k.vertex_count; ++v) {
    float* p = &dag.positions[3 * (k.vertex_offset + v)];
    if (p[0] == 4.0f && p[1] == 1.0f) p[1] = 1.0001f, moved = true;  // inside the cluster's sphere
  }
  ASSERT_TRUE(moved);
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_GT(r.count("CRACK_OPEN_EDGE"), 0u);
  CutCheck c = check_cut(dag, concat({16, 17}, range(4, 16)));  // quadrant 0 coarse, 1..3 leaves
  EXPECT_FALSE(c.ok());
  ASSERT_FALSE(c.violations.empty());
  EXPECT_EQ(c.violations[0].code, "CRACK_OPEN_EDGE");
  EXPECT_GE(c.mismatched_edges, 4u);  // two edges at the moved copy, two at the unmoved one
}

TEST(Verify, MovedVertexOnTheMeshBorderIsCaught) {
  ClusterDag dag = make_hand_dag();
  const DagCluster& k = dag.clusters[16];  // holds (1, 0) on the mesh's open border
  for (uint32_t v = 0; v < k.vertex_count; ++v) {
    float* p = &dag.positions[3 * (k.vertex_offset + v)];
    if (p[0] == 1.0f && p[1] == 0.0f) p[1] = 0.0001f;
  }
  CutCheck c = check_cut(dag, concat({16, 17}, range(4, 16)));
  EXPECT_FALSE(c.ok());
  EXPECT_EQ(c.violations.at(0).code, "CRACK_OPEN_EDGE");
}

TEST(Verify, SimplifiedMeshBorderIsAllowedUnlessStrict) {
  ClusterDag dag = make_hand_dag({{}, 1.0f, true});  // the root keeps every other border vertex
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_TRUE(passes(r));
  EXPECT_GT(r.border_edges_changed, 0u);
  CutCheck c = check_cut(dag, range(24, 26));
  EXPECT_TRUE(c.ok());
  EXPECT_EQ(c.border_edges_changed, 32u + 16u);  // 32 leaf border edges gone, 16 long ones new
  VerifyOptions strict = quick_options();
  strict.strict_border = true;
  VerifyReport rs = verify_dag(dag, strict);
  EXPECT_FALSE(rs.ok());
  EXPECT_GT(rs.count("CRACK_BORDER_CHANGED"), 0u);
  EXPECT_EQ(rs.count("CRACK_OPEN_EDGE"), 0u);
  EXPECT_FALSE(check_cut(dag, prepare_cut_check(dag), range(24, 26), 64, true).ok());
}

TEST(Verify, DanglingIndexIsCaughtAndLaterChecksSkip) {
  ClusterDag dag = make_hand_dag();
  dag.indices[3 * dag.clusters[5].triangle_offset + 1] = uint8_t(dag.clusters[5].vertex_count);
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.count("STRUCT_DANGLING_INDEX"), 1u);
  for (const auto& c : r.checks)
    if (c.check != "structure") {
      EXPECT_FALSE(c.ran) << c.check;
      EXPECT_FALSE(c.skipped_reason.empty());
    }
  EXPECT_FALSE(prepare_cut_check(dag).usable);
  EXPECT_EQ(check_cut(dag, range(0, 16)).violations.at(0).code, "CUT_DAG_UNUSABLE");

  ClusterDag dag2 = make_hand_dag();
  dag2.generated_clusters[3] = 12345;
  EXPECT_EQ(verify_dag(dag2, quick_options()).count("STRUCT_DANGLING_INDEX"), 1u);
  ClusterDag dag3 = make_hand_dag();
  dag3.bvh_nodes[0].children[2] = 77;
  EXPECT_EQ(verify_dag(dag3, quick_options()).count("STRUCT_DANGLING_INDEX"), 1u);
}

TEST(Verify, SiblingWithDifferentParentErrorIsCaught) {
  ClusterDag dag = make_hand_dag();
  dag.clusters[1].parent_error = 10 * test::kLevel1Error;  // one member of group 0 disagrees
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.count("STRUCT_SHARED_VALUE"), 1u);
  EXPECT_GT(r.count("CUT_SIBLING"), 0u);
  EXPECT_GT(r.count("CUT_COVERAGE"), 0u);
}

TEST(Verify, ErrorAboveStoredBoundIsCaught) {
  ClusterDag dag = make_hand_dag();
  // Raise quadrant 3's fan centre (both halves) far above its stored error.
  for (uint32_t c : {22u, 23u}) {
    const DagCluster& k = dag.clusters[c];
    for (uint32_t v = 0; v < k.vertex_count; ++v) {
      float* p = &dag.positions[3 * (k.vertex_offset + v)];
      if (p[0] == 6.0f && p[1] == 6.0f) p[2] = 0.5f;
    }
  }
  VerifyReport r = verify_dag(dag, quick_options());
  EXPECT_EQ(r.count("ERROR_BOUND"), 2u);
  ASSERT_FALSE(r.violations.empty());
  bool found = false;
  for (const auto& v : r.violations)
    if (v.code == "ERROR_BOUND") {
      found = true;
      EXPECT_TRUE(v.index == 22 || v.index == 23);
      EXPECT_NEAR(v.values.at(0).value, 0.5, 1e-6);  // measured
    }
  EXPECT_TRUE(found);
  EXPECT_NEAR(r.error_ratio.max, 0.5 / test::kLevel1Error, 1e-4);
}

TEST(Verify, StructureCorruptionsHaveStableCodes) {
  struct Case {
    const char* code;
    void (*corrupt)(ClusterDag&);
  };
  const Case cases[] = {
      {"STRUCT_EMPTY_CLUSTER", [](ClusterDag& d) { d.clusters[3].triangle_count = 0; }},
      {"STRUCT_CLUSTER_LIMITS", [](ClusterDag& d) { d.clusters[25].vertex_count = 300; }},
      {"STRUCT_LEVEL", [](ClusterDag& d) { d.clusters[18].level = 2; }},
      {"STRUCT_NO_PARENT_GROUP", [](ClusterDag& d) { d.groups[1].generated_count = 0; }},
      {"STRUCT_TERMINAL", [](ClusterDag& d) { d.groups[5].flags = 0; }},
      {"STRUCT_NOT_FINITE", [](ClusterDag& d) { d.positions[7] = std::numeric_limits<float>::quiet_NaN(); }},
      {"STRUCT_GROUP_RANGE", [](ClusterDag& d) { d.groups[0].cluster_count = 5; }},
      {"STRUCT_GENERATED_LINK", [](ClusterDag& d) { d.clusters[17].generating_group = 1; }},
      {"STRUCT_SHARED_VALUE", [](ClusterDag& d) { d.clusters[20].lod_bounds.radius *= 2; }},
      {"STRUCT_CLUSTER_BOUNDS", [](ClusterDag& d) { d.clusters[9].bounds.radius *= 0.5f; }},
      {"STRUCT_GROUP_BOUNDS", [](ClusterDag& d) { d.groups[2].bounds.radius *= 0.5f; }},
      {"STRUCT_BVH_COVERAGE", [](ClusterDag& d) { d.bvh_nodes[0].child_count = 5; d.bvh_nodes[0].group_mask = 0x1F; }},
      {"STRUCT_BVH_BOUNDS", [](ClusterDag& d) { d.bvh_nodes[0].max_parent_error = 1.0f; }},
      {"STRUCT_MATERIAL_OFFSET", [](ClusterDag& d) { d.clusters[2].material_offset += 1; }},
      {"STRUCT_ARRAY_SIZE", [](ClusterDag& d) { d.triangle_materials.pop_back(); }},
      {"STRUCT_ORDER", [](ClusterDag& d) { std::swap(d.groups[3].level, d.groups[4].level); }},
      {"STRUCT_NEGATIVE", [](ClusterDag& d) { d.clusters[0].bounds.radius = -2; }},
      {"STRUCT_EMPTY_DAG", [](ClusterDag& d) { d = ClusterDag{}; }},
  };
  VerifyOptions o = quick_options();
  o.views = 8;
  for (const Case& c : cases) {
    ClusterDag dag = make_hand_dag();
    c.corrupt(dag);
    VerifyReport r = verify_dag(dag, o);
    EXPECT_FALSE(r.ok()) << c.code;
    EXPECT_GT(r.count(c.code), 0u) << c.code << "\n" << verify_report_summary(r);
  }
}

TEST(Verify, ReportIsDeterministicForAnyThreadCount) {
  ClusterDag dag = make_hand_dag();
  dag.clusters[1].parent_error = 10 * test::kLevel1Error;
  dag.clusters[16].triangle_count -= 1;
  VerifyOptions a = quick_options(), b = quick_options();
  a.threads = 1;
  b.threads = 3;
  VerifyReport ra = verify_dag(dag, a), rb = verify_dag(dag, b);
  ASSERT_EQ(ra.violations.size(), rb.violations.size());
  for (size_t i = 0; i < ra.violations.size(); ++i) {
    EXPECT_EQ(ra.violations[i].code, rb.violations[i].code);
    EXPECT_EQ(ra.violations[i].index, rb.violations[i].index);
    EXPECT_EQ(ra.violations[i].message, rb.violations[i].message);
  }
  ASSERT_EQ(ra.counts.size(), rb.counts.size());
  for (size_t i = 0; i < ra.counts.size(); ++i) EXPECT_EQ(ra.counts[i].count, rb.counts[i].count);
}

TEST(Verify, ViolationStorageIsCappedButCountsAreComplete) {
  ClusterDag dag = make_hand_dag();
  for (auto& k : dag.clusters) k.bounds.radius *= 0.25f;  // 26 STRUCT_CLUSTER_BOUNDS (and more)
  VerifyOptions o = quick_options();
  o.max_stored_per_code = 3;
  VerifyReport r = verify_dag(dag, o);
  EXPECT_EQ(r.count("STRUCT_CLUSTER_BOUNDS"), 26u);
  size_t stored = 0;
  for (const auto& v : r.violations) stored += v.code == "STRUCT_CLUSTER_BOUNDS";
  EXPECT_EQ(stored, 3u);
}

TEST(Verify, JsonReportIsValidAndComplete) {
  ClusterDag dag = make_hand_dag();
  dag.clusters[16].triangle_count -= 1;
  VerifyReport r = verify_dag(dag, quick_options());
  auto j = nlohmann::json::parse(verify_report_json(r, "hand"));
  EXPECT_EQ(j["mesh"], "hand");
  EXPECT_EQ(j["ok"], false);
  EXPECT_EQ(j["checks"].size(), 5u);
  EXPECT_GT(j["violation_counts"]["CRACK_OPEN_EDGE"].get<uint64_t>(), 0u);
  EXPECT_FALSE(j["violations"].empty());
  EXPECT_TRUE(j["error_ratio"].contains("p95"));
  // +inf values (terminal errors) must not break the JSON.
  ClusterDag bad = make_hand_dag();
  test::set_group_parent_error(bad, 4, 0.01f);
  EXPECT_TRUE(nlohmann::json::accept(verify_report_json(verify_dag(bad, quick_options()))));
}

TEST(Verify, ParseChecks) {
  uint32_t c = 0;
  EXPECT_TRUE(parse_verify_checks("structure,crack", &c));
  EXPECT_EQ(c, uint32_t(kCheckStructure | kCheckCrack));
  EXPECT_TRUE(parse_verify_checks("all", &c));
  EXPECT_EQ(c, uint32_t(kCheckAll));
  EXPECT_FALSE(parse_verify_checks("structure,bogus", &c));
  EXPECT_FALSE(parse_verify_checks("", &c));
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

TEST(Verify, QuadtreeDagPassesEveryCheck) {
  for (uint32_t k : {2u, 3u, 5u}) {
    ClusterDag dag = test::make_quadtree_dag(k);
    VerifyOptions o = quick_options();
    o.views = 32;
    VerifyReport r = verify_dag(dag, o);
    EXPECT_TRUE(passes(r)) << "k = " << k;
    EXPECT_EQ(r.levels, k - 1);
    if (k > 2) {
      EXPECT_NEAR(r.error_ratio.max, 2.0 / 3.0, 1e-6);
    }
  }
}

}  // namespace
}  // namespace vgeo
