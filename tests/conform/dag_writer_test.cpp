// spec/vgeodag_writer.h as another builder uses it: the C99 example program
// (tests/conform/vgeodag_writer_example.c) writes a valid DAG that `vgeo verify` accepts and a
// broken one it rejects with exactly the planted codes; containment misses carry their size.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "conform/junit_check.h"
#include "support/run_command.h"

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

}  // namespace
