// spec/vgeodag_writer.h as another builder uses it: the C99 worked example
// (spec/examples/vgeodag_writer_example.c, built as strict C99 by tests/CMakeLists.txt) writes a
// valid DAG that `vgeo verify` accepts and a broken one it rejects with exactly the planted
// codes; containment misses carry their size. The header's sphere rules are checked directly:
// a zero-initialised group has no builder sphere, a builder sphere is folded in first (kept
// whole when it encloses the members), and a builder's own BVH gets conservative spheres.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "conform/junit_check.h"
#include "support/run_command.h"

#define VGEODAG_WRITER_IMPLEMENTATION
#include "../../spec/vgeodag_writer.h"

namespace fs = std::filesystem;
using vgeo::test::run_cli;
using vgeo::test::run_command;

namespace {

struct WriterFiles {
  fs::path dir, good, broken;
  WriterFiles() {
    dir = fs::temp_directory_path() / ("vgeo_dag_writer_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    good = dir / "good.vgeodag";
    broken = dir / "broken.vgeodag";
  }
  ~WriterFiles() { fs::remove_all(dir); }
};

nlohmann::json read_json(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(f);
}

TEST(DagWriter, CProgramRoundTripsThroughVerify) {
  WriterFiles files;
  std::string command = VGEO_DAG_WRITER_EXAMPLE;
  for (const fs::path& p : {files.good, files.broken}) command.append(" '").append(p.string()).append("'");
  auto written = run_command(command);
  ASSERT_EQ(written.exit_code, 0) << written.output;

  auto good = run_cli("verify '" + files.good.string() + "' --json '" + (files.dir / "good.json").string() + "'");
  EXPECT_EQ(good.exit_code, 0) << good.output;
  nlohmann::json gj = read_json(files.dir / "good.json");
  EXPECT_TRUE(gj["ok"].get<bool>());
  EXPECT_EQ(gj["meshes"][0]["levels"].get<int>(), 2);

  auto broken = run_cli("verify '" + files.broken.string() + "' --json '" + (files.dir / "broken.json").string() + "'");
  EXPECT_EQ(broken.exit_code, 1) << broken.output;
  nlohmann::json bj = read_json(files.dir / "broken.json");
  const nlohmann::json& counts = bj["meshes"][0]["violation_counts"];
  EXPECT_EQ(counts, (nlohmann::json{{"ERROR_BOUND", 1}, {"STRUCT_CLUSTER_BOUNDS", 1}})) << counts.dump();
  // The sphere was shrunk by 3 float ulps from a radius the writer rounds up by ≥ 1 ulp: the
  // miss is 1..3 ulps and is reported as such (rounding, not geometry).
  bool found = false;
  for (const auto& v : bj["meshes"][0]["violations"]) {
    if (v["code"] != "STRUCT_CLUSTER_BOUNDS") continue;
    found = true;
    double ulps = 0, relative = 0;
    for (const auto& value : v["values"].items()) {
      if (value.key() == "excess_ulps") ulps = value.value().get<double>();
      if (value.key() == "excess_relative") relative = value.value().get<double>();
    }
    EXPECT_GE(ulps, 1.0) << v.dump();
    EXPECT_LE(ulps, 3.0) << v.dump();
    EXPECT_GT(relative, 0.0);
    EXPECT_LT(relative, 4.0 / (1 << 23));
    EXPECT_NE(v["message"].get<std::string>().find("ulp"), std::string::npos);
  }
  EXPECT_TRUE(found);
}

TEST(DagWriter, VerifyJunitCarriesTheCodes) {
  WriterFiles files;
  std::string command = VGEO_DAG_WRITER_EXAMPLE;
  for (const fs::path& p : {files.good, files.broken}) command.append(" '").append(p.string()).append("'");
  ASSERT_EQ(run_command(command).exit_code, 0);
  const std::string xml = (files.dir / "broken.xml").string();
  EXPECT_EQ(run_cli("verify '" + files.broken.string() + "' --quiet --junit '" + xml + "'").exit_code, 1);
  std::string cases = vgeo::test::checked_junit(xml);
  EXPECT_NE(cases.find("vgeo.verify.mesh0.structure: failed STRUCT_CLUSTER_BOUNDS"), std::string::npos) << cases;
  EXPECT_NE(cases.find("vgeo.verify.mesh0.error_bound: failed ERROR_BOUND"), std::string::npos) << cases;
  EXPECT_NE(cases.find("vgeo.verify.mesh0.cut: passed"), std::string::npos) << cases;

  const std::string good_xml = (files.dir / "good.xml").string();
  EXPECT_EQ(run_cli("verify '" + files.good.string() + "' --quiet --junit '" + good_xml + "'").exit_code, 0);
  cases = vgeo::test::checked_junit(good_xml);
  EXPECT_EQ(cases.find("failed"), std::string::npos) << cases;

  // A file the decoder rejects is one failing testcase carrying the decoder's code (exit 3).
  const fs::path truncated = files.dir / "truncated.vgeodag";
  fs::copy_file(files.good, truncated);
  fs::resize_file(truncated, 100);
  const std::string bad_xml = (files.dir / "truncated.xml").string();
  EXPECT_EQ(run_cli("verify '" + truncated.string() + "' --junit '" + bad_xml + "'").exit_code, 3);
  cases = vgeo::test::checked_junit(bad_xml);
  EXPECT_NE(cases.find("vgeo.verify.decode: failed DAGFILE_TRUNCATED"), std::string::npos) << cases;
}

// The example's DAG (two leaf clusters of a 2x2-quad grid with a raised centre, one group
// generating the flat square, a terminal root group), moved by `offset` in x and y, with
// zero-initialised groups as a C builder's `= {0}` leaves them.
struct GridDag {
  std::vector<float> positions;
  std::vector<uint8_t> indices;
  vgeodag_cluster clusters[3] = {};
  vgeodag_group groups[2] = {};
  uint32_t generated[1] = {2};
  vgeodag_mesh mesh = {};
  explicit GridDag(float offset) {
    auto vertex = [&](int x, int y) {
      positions.insert(positions.end(), {float(x) + offset, float(y) + offset, (x == 1 && y == 1) ? 0.1f : 0.0f});
    };
    uint32_t v = 0, t = 0;
    for (uint32_t c = 0; c < 2; ++c) {
      clusters[c].vertex_offset = v, clusters[c].triangle_offset = t;
      for (int x = 0; x < 2; ++x)
        for (int y = 0; y < 3; ++y) vertex(int(c) + x, y), ++v;
      for (uint8_t y = 0; y < 2; ++y) {
        for (uint8_t q : {0, 3, 4, 0, 4, 1}) indices.push_back(uint8_t(q + y));
        t += 2;
      }
      clusters[c].vertex_count = 6, clusters[c].triangle_count = 4;
      clusters[c].generating_group = VGEODAG_NONE;
    }
    clusters[2].vertex_offset = v, clusters[2].triangle_offset = t;
    vertex(0, 0), vertex(2, 0), vertex(2, 2), vertex(0, 2), v += 4;
    for (uint8_t q : {0, 1, 2, 0, 2, 3}) indices.push_back(q);
    t += 2;
    clusters[2].vertex_count = 4, clusters[2].triangle_count = 2;
    clusters[2].group = 1, clusters[2].generating_group = 0, clusters[2].level = 1;
    groups[0].cluster_count = 2, groups[0].generated_count = 1, groups[0].parent_error = 0.125f;
    groups[1].first_cluster = 2, groups[1].cluster_count = 1, groups[1].level = 1;
    groups[1].flags = VGEODAG_GROUP_TERMINAL;
    mesh.clusters = clusters, mesh.cluster_count = 3, mesh.groups = groups, mesh.group_count = 2;
    mesh.generated_clusters = generated, mesh.generated_count = 1;
    mesh.positions = positions.data(), mesh.vertex_count = v, mesh.indices = indices.data(), mesh.triangle_count = t;
  }
};

double sphere_distance(const vgeodag_sphere& a, const vgeodag_sphere& b) {
  return std::sqrt(std::pow(double(a.x) - b.x, 2) + std::pow(double(a.y) - b.y, 2) + std::pow(double(a.z) - b.z, 2));
}
bool encloses(const vgeodag_sphere& outer, const vgeodag_sphere& inner) {
  return sphere_distance(outer, inner) + inner.r <= outer.r;
}

TEST(DagWriter, ZeroInitialisedGroupHasNoBuilderSphere) {
  // Far from the origin: a zero sphere counted as present would pull the origin into the
  // parent bounds (radius ≈ 142 here instead of ≈ 1.6).
  GridDag grid(100.0f);
  ASSERT_EQ(vgeodag_derive(&grid.mesh), VGEODAG_OK);
  const vgeodag_group& g = grid.groups[0];
  EXPECT_TRUE(encloses(g.parent_bounds, grid.clusters[0].lod_bounds));
  EXPECT_TRUE(encloses(g.parent_bounds, grid.clusters[1].lod_bounds));
  EXPECT_LT(g.parent_bounds.r, 2.0f);
  EXPECT_GT(g.parent_bounds.x, 99.0f);
  // A negative or NaN radius is "none" too; the result is the same bits.
  for (float none : {-1.0f, std::nanf("")}) {
    GridDag other(100.0f);
    other.groups[0].builder_sphere.r = none;
    ASSERT_EQ(vgeodag_derive(&other.mesh), VGEODAG_OK);
    EXPECT_EQ(std::memcmp(&other.groups[0].parent_bounds, &g.parent_bounds, sizeof g.parent_bounds), 0);
  }
}

TEST(DagWriter, BuilderSphereIsFoldedInFirst) {
  // A builder sphere that encloses every member's lod_bounds is kept: same centre, radius
  // rounded up by at most a few ulps (not regrown by re-folding the members).
  GridDag grid(100.0f);
  const vgeodag_sphere mine{101.0f, 101.0f, 0.05f, 3.0f};
  grid.groups[0].builder_sphere = mine;
  ASSERT_EQ(vgeodag_derive(&grid.mesh), VGEODAG_OK);
  const vgeodag_sphere& p = grid.groups[0].parent_bounds;
  EXPECT_EQ(p.x, mine.x);
  EXPECT_EQ(p.y, mine.y);
  EXPECT_EQ(p.z, mine.z);
  EXPECT_GE(p.r, mine.r);
  EXPECT_LE(p.r, mine.r * (1.0f + 4.0f / (1 << 23)));
  EXPECT_TRUE(encloses(p, mine));
  // Generated clusters carry it as their lod_bounds, bit for bit.
  EXPECT_EQ(std::memcmp(&grid.clusters[2].lod_bounds, &p, sizeof p), 0);
  // One that does not enclose the members still yields a sphere enclosing both.
  GridDag small(100.0f);
  const vgeodag_sphere tight{101.0f, 101.0f, 0.0f, 0.5f};
  small.groups[0].builder_sphere = tight;
  ASSERT_EQ(vgeodag_derive(&small.mesh), VGEODAG_OK);
  EXPECT_TRUE(encloses(small.groups[0].parent_bounds, tight));
  EXPECT_TRUE(encloses(small.groups[0].parent_bounds, small.clusters[0].lod_bounds));
}

TEST(DagWriter, BuilderBvhGetsConservativeSpheres) {
  GridDag grid(100.0f);
  ASSERT_EQ(vgeodag_derive(&grid.mesh), VGEODAG_OK);
  // Root (node 0) → node 1 → both groups; the builder's own sphere on node 1's bounds.
  vgeodag_bvh_node nodes[2] = {};
  nodes[0].child_count = 1, nodes[0].children[0] = 1;
  nodes[1].child_count = 2, nodes[1].group_mask = 3u, nodes[1].children[0] = 0, nodes[1].children[1] = 1;
  const vgeodag_sphere mine{101.0f, 101.0f, 0.0f, 4.0f};
  nodes[1].bounds = mine;
  ASSERT_EQ(vgeodag_derive_bvh(&grid.mesh, nodes, 2), VGEODAG_OK);
  for (const vgeodag_group& g : grid.groups) {
    EXPECT_TRUE(encloses(nodes[1].bounds, g.bounds));
    EXPECT_TRUE(encloses(nodes[1].lod_bounds, g.parent_bounds));
  }
  EXPECT_EQ(nodes[1].bounds.x, mine.x);  // folded in first: kept whole
  EXPECT_TRUE(encloses(nodes[0].bounds, nodes[1].bounds));
  EXPECT_TRUE(encloses(nodes[0].lod_bounds, nodes[1].lod_bounds));
  EXPECT_TRUE(std::isinf(nodes[0].max_parent_error));  // a terminal group below
  EXPECT_EQ(nodes[0].children[1], VGEODAG_NONE);
  // The file verifies with this BVH.
  WriterFiles files;
  grid.mesh.bvh_nodes = nodes, grid.mesh.bvh_node_count = 2;
  vgeodag_scene scene = {};
  scene.meshes = &grid.mesh, scene.mesh_count = 1;
  ASSERT_EQ(vgeodag_write_file(files.good.string().c_str(), &scene), VGEODAG_OK);
  auto verified = run_cli("verify '" + files.good.string() + "'");
  EXPECT_EQ(verified.exit_code, 0) << verified.output;

  // Not a tree from node 0: a cycle back to the root, a node not reached, a group out of range.
  vgeodag_bvh_node cycle[2] = {};
  cycle[0].child_count = 1, cycle[0].children[0] = 1;
  cycle[1].child_count = 1, cycle[1].children[0] = 0;
  EXPECT_EQ(vgeodag_derive_bvh(&grid.mesh, cycle, 2), VGEODAG_ERROR_ARGUMENT);
  vgeodag_bvh_node unreached[2] = {};
  unreached[0].child_count = 2, unreached[0].group_mask = 3u, unreached[0].children[1] = 1;
  EXPECT_EQ(vgeodag_derive_bvh(&grid.mesh, unreached, 2), VGEODAG_ERROR_ARGUMENT);
  vgeodag_bvh_node bad_group[1] = {};
  bad_group[0].child_count = 1, bad_group[0].group_mask = 1u, bad_group[0].children[0] = 7;
  EXPECT_EQ(vgeodag_derive_bvh(&grid.mesh, bad_group, 1), VGEODAG_ERROR_ARGUMENT);
}

}  // namespace
