// The opt-in certified_bound check (ERROR_CERTIFIED, lib/vgeo/verify/verify_certify.cpp,
// spec/invariants.md §5 "Certified bound") on the hand-built DAG, independently of the builder:
// its raised fans deviate at most their apex height, below their stored error, so every cluster
// is proven; a stored error below the apex height is a point beyond it. The check is parsed by
// name and is not part of "all" (the default build does not promise it). A tent under a flat
// square deviates most between the lattice's samples: stored below that, only this check fires.
#include <gtest/gtest.h>

#include "verify/hand_dag.h"
#include "vgeo/verify/verify.h"

// Own namespace: test files are compiled as one unity source.
namespace vgeo::certified_bound_test {
namespace {

VerifyOptions certify_only() {
  VerifyOptions o;
  o.checks = kCheckCertifiedBound;
  o.threads = 2;
  return o;
}

TEST(CertifiedBound, ProvesTheHandDag) {
  const VerifyReport r = verify_dag(test::make_hand_dag(), certify_only());
  EXPECT_TRUE(r.ok());
  ASSERT_EQ(r.checks.size(), 1u);
  EXPECT_EQ(r.checks[0].check, "certified_bound");
  EXPECT_TRUE(r.checks[0].ran);
  EXPECT_EQ(r.checks[0].items, 10u);  // the non-leaf clusters: 8 at level 1, 2 at level 2
  // Far from the origin (float positions, the tolerance in ulps of the largest coordinate).
  EXPECT_TRUE(verify_dag(test::make_hand_dag({{1e4f, -2e4f, 5e3f}, 1.0f}), certify_only()).ok());
}

TEST(CertifiedBound, FiresBelowTheApexHeight) {
  ClusterDag dag = test::make_hand_dag();
  // A level-1 group's clusters (and the group: D5 shared values) claim less than their apex
  // height: a corner of a fan triangle is beyond the stored error.
  uint32_t lowered = 0;
  for (size_t c = 0; c < dag.clusters.size(); ++c)
    if (dag.clusters[c].level == 1 && dag.clusters[c].generating_group == 0) {
      dag.clusters[c].lod_error = 0.5f * test::kLevel1Height;
      ++lowered;
    }
  dag.groups[0].parent_error = 0.5f * test::kLevel1Height;
  ASSERT_GT(lowered, 0u);
  const VerifyReport r = verify_dag(dag, certify_only());
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.count("ERROR_CERTIFIED"), lowered);
  for (const Violation& v : r.violations) {
    EXPECT_EQ(v.code, "ERROR_CERTIFIED");
    EXPECT_EQ(v.check, "certified_bound");
    EXPECT_EQ(dag.clusters[v.index].generating_group, 0u);
  }
}

// A tent (four leaf triangles, apex raised by kTentHeight over the unit square's centre) and its
// flat two-triangle simplification: the deviation peaks at the square's centre (≈ the apex
// height), between the 3-step lattice's points (≈ 2/3 of it), and every corner of the flat
// triangles is a leaf vertex (distance 0). Stored kUnderstated: the samples pass, the check must
// not; stored the apex height: proven.
constexpr float kTentHeight = 0.1f;
constexpr float kUnderstated = 0.08f;  // above the lattice's ≈ 0.065, below the centre's ≈ 0.098

ClusterDag tent_dag(float stored) {
  using namespace test::hand_dag_detail;
  ClusterDag dag;
  dag.groups.resize(2);
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{1, 1, 0}, d{0, 1, 0}, apex{0.5f, 0.5f, kTentHeight};
  dag.groups[0].first_cluster = 0;
  dag.groups[0].cluster_count = 1;
  add_cluster(dag, {{{a, b, apex}}, {{b, c, apex}}, {{c, d, apex}}, {{d, a, apex}}}, 0, kNone, 0);
  dag.groups[0].first_generated = 0;
  dag.groups[0].generated_count = 1;
  dag.groups[1].first_cluster = 1;
  dag.groups[1].cluster_count = 1;
  dag.groups[1].level = 1;
  dag.groups[1].flags = kGroupTerminal;
  dag.generated_clusters.push_back(add_cluster(dag, {{{a, b, c}}, {{a, c, d}}}, 1, 0, 1));
  dag.level_count = 2;
  finish(dag, {stored, kTerminalError});
  return dag;
}

TEST(CertifiedBound, FiresBetweenTheSamples) {
  VerifyOptions o = certify_only();
  o.checks |= kCheckErrorBound;
  const VerifyReport under = verify_dag(tent_dag(kUnderstated), o);
  EXPECT_EQ(under.count("ERROR_BOUND"), 0u);  // the samples do not see it
  EXPECT_EQ(under.count("ERROR_CERTIFIED"), 1u);
  EXPECT_TRUE(verify_dag(tent_dag(kTentHeight), o).ok());
}

TEST(CertifiedBound, ParsedByNameNotInAll) {
  uint32_t c = 0;
  EXPECT_TRUE(parse_verify_checks("error_bound,certified_bound", &c));
  EXPECT_EQ(c, uint32_t(kCheckErrorBound | kCheckCertifiedBound));
  EXPECT_TRUE(parse_verify_checks("all", &c));
  EXPECT_EQ(c & kCheckCertifiedBound, 0u);
  EXPECT_STREQ(verify_check_name(kCheckCertifiedBound), "certified_bound");
}

}  // namespace
}  // namespace vgeo::certified_bound_test
