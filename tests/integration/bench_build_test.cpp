// `vgeo bench build`'s throughput ceiling (tools/vgeo/bench_build.cpp, bench_ceiling.h): the
// arithmetic on given seconds, and the suite's JSON on a small sphere: the set of N one-thread
// builds carries its children's stage seconds per repetition, and the reported medians are the
// medians of the per-repetition ratios computed from them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../../tools/vgeo/bench_ceiling.h"
#include "support/paths.h"
#include "support/run_command.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;
using bench::ceiling_ratios;
using bench::CeilingSeconds;

TEST(BenchBuildCeiling, RatiosFromGivenSeconds) {
  // 1M-sphere-like seconds: t1 2.4 s, t2 1.35 s, two one-thread builds at once 2.5 s.
  const bench::CeilingRatios r = ceiling_ratios(CeilingSeconds{2.4, 1.35, 2.5}, 2);
  EXPECT_DOUBLE_EQ(r.ceiling, 2 * 2.4 / 2.5);
  EXPECT_DOUBLE_EQ(r.speedup, 2.4 / 1.35);
  EXPECT_DOUBLE_EQ(r.share, r.speedup / r.ceiling);
  // The one-thread time cancels: the share is the set's time over N x the N-thread time.
  EXPECT_NEAR(r.share, 2.5 / (2 * 1.35), 1e-12);
  // A stage whose ceiling is 1.85x gives 1.8x only at 1.8 / 1.85 = 97% of it.
  const bench::CeilingRatios s = ceiling_ratios(CeilingSeconds{1.85, 1.0, 2.0}, 2);
  EXPECT_DOUBLE_EQ(s.ceiling, 1.85);
  EXPECT_NEAR(ceiling_ratios(CeilingSeconds{1.85, 1.85 / 1.8, 2.0}, 2).share, 1.8 / 1.85, 1e-12);
  // An N-thread build that is exactly N one-thread builds' work split with no loss reaches the ceiling.
  EXPECT_DOUBLE_EQ(ceiling_ratios(CeilingSeconds{3.0, 1.1, 3.3}, 3).share, 1.0);
  EXPECT_DOUBLE_EQ(ceiling_ratios(CeilingSeconds{3.0, 1.1, 3.3}, 3).ceiling, 3 * 3.0 / 3.3);
}

TEST(BenchBuildCeiling, MissingTimesGiveNaNNotInfinity) {
  // A stage that took no measurable time (or a failed read) must drop out of the medians.
  EXPECT_TRUE(std::isnan(ceiling_ratios(CeilingSeconds{1.0, 0.5, 0.0}, 2).ceiling));
  EXPECT_TRUE(std::isnan(ceiling_ratios(CeilingSeconds{1.0, 0.5, 0.0}, 2).share));
  EXPECT_TRUE(std::isnan(ceiling_ratios(CeilingSeconds{1.0, 0.0, 1.0}, 2).speedup));
  EXPECT_TRUE(std::isnan(ceiling_ratios(CeilingSeconds{0.0, 0.5, 1.0}, 2).ceiling));
}

double median(std::vector<double> xs) {
  std::sort(xs.begin(), xs.end());
  const size_t m = xs.size() / 2;
  return xs.size() % 2 ? xs[m] : 0.5 * (xs[m - 1] + xs[m]);
}

nlohmann::json run_bench_build(const fs::path& out, const std::string& args) {
  auto r = test::run_command("VGEO_BUILD_INPUTS=sphere:2000 '" + test::cli_path() + "' bench build " + args +
                             " --out '" + out.string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::ifstream f(out / "report.json");
  const nlohmann::json report = nlohmann::json::parse(f);
  for (const auto& suite : report["suites"])
    if (suite["name"] == "build") return suite;
  ADD_FAILURE() << report.dump();
  return {};
}

// The suite's ceiling section for N one-thread builds at once, checked against its own raw seconds.
void check_ceiling(const nlohmann::json& suite, unsigned n, size_t repetitions) {
  const nlohmann::json& meshes = suite["data"]["meshes"];
  ASSERT_EQ(meshes.size(), 1u) << suite.dump();
  const nlohmann::json& mesh = meshes[0];
  EXPECT_TRUE(mesh["same_bytes_at_once"].get<bool>());
  ASSERT_EQ(mesh["runs"].size(), 4u);
  EXPECT_EQ(mesh["runs"][3]["concurrent_builds"], n);
  EXPECT_EQ(mesh["runs"][3]["threads"], 1);
  EXPECT_EQ(mesh["runs"][2]["threads"], n);
  const nlohmann::json& c = mesh["throughput_ceiling"];
  EXPECT_EQ(c["concurrent_builds"], n);
  ASSERT_EQ(c["repetitions"].size(), repetitions);
  for (const char* q : {"wall", "import", "build", "write"}) {
    std::vector<double> ceiling, speedup, share;
    for (const nlohmann::json& rep : c["repetitions"]) {
      const nlohmann::json& set = rep["concurrent"];
      ASSERT_EQ(set["children_stage_seconds"].size(), n);
      CeilingSeconds s;
      if (std::string(q) == "wall") {
        s = {rep["one_thread"]["wall"], rep["n_threads"]["wall"], set["wall"]};
        // Every child's stages ran within the set's wall, as a lone build's within its own.
        for (const nlohmann::json& child : set["children_stage_seconds"])
          EXPECT_LT(child["import"].get<double>() + child["build"].get<double>() + child["write"].get<double>(),
                    set["wall"].get<double>());
      } else {
        std::vector<double> children;
        for (const nlohmann::json& child : set["children_stage_seconds"]) children.push_back(child[q]);
        // The set's stage time is the children's median, and never above their max.
        EXPECT_DOUBLE_EQ(set["stage_seconds"][q].get<double>(), median(children));
        EXPECT_DOUBLE_EQ(set["stage_seconds_max"][q].get<double>(), *std::max_element(children.begin(), children.end()));
        s = {rep["one_thread"]["stage_seconds"][q], rep["n_threads"]["stage_seconds"][q], median(children)};
      }
      const bench::CeilingRatios r = ceiling_ratios(s, n);
      ceiling.push_back(r.ceiling);
      speedup.push_back(r.speedup);
      share.push_back(r.share);
    }
    // Medians of per-repetition ratios, not ratios of medians.
    EXPECT_DOUBLE_EQ(c[q]["ceiling"]["median"].get<double>(), median(ceiling)) << q;
    EXPECT_DOUBLE_EQ(c[q]["speedup"]["median"].get<double>(), median(speedup)) << q;
    EXPECT_DOUBLE_EQ(c[q]["share_of_ceiling"]["median"].get<double>(), median(share)) << q;
    EXPECT_GT(c[q]["ceiling"]["median"].get<double>(), 0) << q;
  }
  // No note: the builds at once wrote the same bytes, and the ceiling was measured.
  EXPECT_TRUE(suite["notes"].empty()) << suite["notes"].dump();
}

TEST(BenchBuildCeiling, SuiteReportsTheSetOfOneThreadBuildsAtOnce) {
  const fs::path dir = fs::temp_directory_path() / ("vgeo_bench_build_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  check_ceiling(run_bench_build(dir / "t2", "--threads 2 --repeat 3"), 2, 3);
  // N > 2: N one-thread builds at once against one N-thread build.
  check_ceiling(run_bench_build(dir / "t3", "--threads 3 --repeat 1"), 3, 1);
  std::ifstream md(dir / "t2" / "report.md");
  const std::string text(std::istreambuf_iterator<char>(md), {});
  EXPECT_NE(text.find("Throughput ceiling: 2 one-thread builds at once against one 2-thread build"), std::string::npos) << text;
  // One thread: nothing to compare, said so instead of a table of 1x.
  const nlohmann::json one = run_bench_build(dir / "t1", "--threads 1 --repeat 1");
  EXPECT_EQ(one["data"]["meshes"][0]["runs"].size(), 3u);
  EXPECT_FALSE(one["data"]["meshes"][0].contains("throughput_ceiling"));
  EXPECT_NE(one["notes"].dump().find("no throughput ceiling"), std::string::npos) << one["notes"].dump();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace vgeo
