// `vgeo compare`: the meshopt and openmesh builds of one mesh give the table, `--fail-if`
// decides the exit code (0 / 1), and the JUnit report carries COMPARE_THRESHOLD; different
// meshes and bad thresholds are rejected with their codes (spec/conform.md §2, spec/errors.md).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "conform/junit_check.h"
#include "support/run_command.h"

namespace fs = std::filesystem;
using vgeo::test::run_cli;

namespace {

struct Builds {
  fs::path dir;
  std::string meshopt, openmesh, pages, other;
  Builds() {
    dir = fs::temp_directory_path() / ("vgeo_compare_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    auto p = [&](const char* name) { return (dir / name).string(); };
    meshopt = p("m.vgeodag"), openmesh = p("o.vgeodag"), pages = p("m.vgeopage"), other = p("t.vgeodag");
    EXPECT_EQ(run_cli("gen sphere -n 3000 -o '" + p("s.obj") + "'").exit_code, 0);
    EXPECT_EQ(run_cli("gen torus -n 2000 -o '" + p("t.obj") + "'").exit_code, 0);
    EXPECT_EQ(run_cli("build '" + p("s.obj") + "' -o '" + meshopt + "'").exit_code, 0);
    EXPECT_EQ(run_cli("build '" + p("s.obj") + "' --simplifier openmesh -o '" + openmesh + "'").exit_code, 0);
    EXPECT_EQ(run_cli("build '" + p("s.obj") + "' -o '" + pages + "'").exit_code, 0);
    EXPECT_EQ(run_cli("build '" + p("t.obj") + "' -o '" + other + "'").exit_code, 0);
  }
  ~Builds() { fs::remove_all(dir); }
};

// Built once per test binary run (four small builds shared by the tests below).
const Builds& builds() {
  static const Builds b;
  return b;
}

TEST(Compare, MeshoptVsOpenmeshTableAndThresholds) {
  const Builds& b = builds();
  const fs::path dir = b.dir / "thresholds";
  fs::create_directories(dir);
  const std::string json = (dir / "c.json").string(), xml = (dir / "c.xml").string();
  auto ok = run_cli("compare '" + b.meshopt + "' '" + b.openmesh + "' --fail-if 'levels>2' --fail-if 'b.error_bound_violations>0' --json '" + json + "'");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  for (const char* row : {"levels", "stored_triangles", "root_triangles", "drawn_triangles", "error_ratio_median",
                          "file_bytes", "fail-if levels>2: B/A = "})
    EXPECT_NE(ok.output.find(row), std::string::npos) << row << "\n" << ok.output;
  std::ifstream f(json);
  nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_TRUE(j["ok"].get<bool>());
  EXPECT_EQ(j["views"].get<int>(), 56);
  // Same mesh, same leaves: the leaf triangles are counted in stored_triangles of both.
  EXPECT_GE(j["metrics"]["stored_triangles"]["b"].get<double>(), 3000.0);
  const double drawn_ratio = j["metrics"]["drawn_triangles"]["ratio"].get<double>();
  EXPECT_GT(drawn_ratio, 0.0);

  // A threshold the pair cannot meet (B/A of levels below 0.5) fails with exit 1 and in JUnit.
  auto bad = run_cli("compare '" + b.meshopt + "' '" + b.openmesh + "' --quiet --fail-if 'levels<2' --fail-if 'clusters>100' --junit '" + xml + "'");
  EXPECT_EQ(bad.exit_code, 1) << bad.output;
  std::string cases = vgeo::test::checked_junit(xml);
  EXPECT_NE(cases.find("vgeo.compare.fail-if levels<2: failed COMPARE_THRESHOLD"), std::string::npos) << cases;
  EXPECT_NE(cases.find("vgeo.compare.fail-if clusters>100: passed"), std::string::npos) << cases;
  EXPECT_NE(cases.find("vgeo.compare.same_mesh: passed"), std::string::npos) << cases;

  // A page file of the same mesh compares (quantized positions, same leaves).
  EXPECT_EQ(run_cli("compare '" + b.meshopt + "' '" + b.pages + "' --quiet --fail-if 'b.error_bound_violations>0'").exit_code, 0);
}

TEST(Compare, RejectsOtherMeshesAndBadThresholds) {
  const Builds& b = builds();
  auto other = run_cli("compare '" + b.meshopt + "' '" + b.other + "'");
  EXPECT_EQ(other.exit_code, 3) << other.output;
  EXPECT_NE(other.output.find("error[COMPARE_NOT_SAME_MESH]"), std::string::npos) << other.output;
  for (const char* expr : {"foo>1", "levels", "levels>", "levels>x", "b.>1"}) {
    auto r = run_cli("compare '" + b.meshopt + "' '" + b.openmesh + "' --fail-if '" + expr + "'");
    EXPECT_EQ(r.exit_code, 2) << expr << "\n" << r.output;
    EXPECT_NE(r.output.find("error[COMPARE_BAD_THRESHOLD]"), std::string::npos) << r.output;
  }
  auto mesh = run_cli("compare '" + b.meshopt + "' '" + b.openmesh + "' --mesh 3");
  EXPECT_EQ(mesh.exit_code, 3);
  EXPECT_NE(mesh.output.find("error[COMPARE_NO_MESH]"), std::string::npos) << mesh.output;
}

}  // namespace
