// `vgeo verify FILE --json`: exit codes and the JSON report (spec/errors.md).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "support/paths.h"
#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/dag_io.h"
#include "verify/hand_dag.h"
#include <nlohmann/json.hpp>
#include <cstdlib>
#include <sys/wait.h>
#include <unistd.h>
#include "vgeo/core/error.h"
#include "vgeo/verify/verify.h"

namespace vgeo {
namespace {

// ---- the CLI: `vgeo verify FILE --json` exit codes and report ----

int run_cli(const std::string& args) {
  int status = std::system((test::cli_path() + " " + args + " > /dev/null 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(VerifyCli, ExitCodesAndJsonReport) {
  const auto dir = std::filesystem::temp_directory_path() / ("vgeo_verify_cli_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  BuiltScene scene;
  scene.meshes.push_back(test::make_hand_dag());
  scene.meshes.push_back(test::make_quadtree_dag(4));
  write_dag_file((dir / "good.vgeodag").string(), scene);
  EXPECT_EQ(run_cli("verify " + (dir / "good.vgeodag").string() + " --json " + (dir / "good.json").string()), 0);
  std::ifstream gj(dir / "good.json");
  nlohmann::json good = nlohmann::json::parse(gj);
  EXPECT_EQ(good["ok"], true);
  EXPECT_EQ(good["meshes"].size(), 2u);

  scene.meshes[1].clusters[5].parent_error = 123.0f;  // STRUCT_SHARED_VALUE, CUT_*
  write_dag_file((dir / "bad.vgeodag").string(), scene);
  EXPECT_EQ(run_cli("verify " + (dir / "bad.vgeodag").string() + " --json " + (dir / "bad.json").string()), 1);
  std::ifstream bj(dir / "bad.json");
  nlohmann::json bad = nlohmann::json::parse(bj);
  EXPECT_EQ(bad["ok"], false);
  EXPECT_EQ(bad["meshes"][0]["ok"], true);
  EXPECT_GT(bad["meshes"][1]["violation_counts"]["STRUCT_SHARED_VALUE"].get<int>(), 0);

  { std::ofstream(dir / "garbage.vgeodag") << "not a dag"; }
  EXPECT_EQ(run_cli("verify " + (dir / "garbage.vgeodag").string()), 3);
  EXPECT_EQ(run_cli("verify " + (dir / "missing.vgeodag").string()), 4);
  EXPECT_EQ(run_cli("verify " + (dir / "good.vgeodag").string() + " --checks nonsense"), 2);
  EXPECT_EQ(run_cli("verify " + (dir / "good.vgeodag").string() + " --checks structure,crack --views 4"), 0);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vgeo
