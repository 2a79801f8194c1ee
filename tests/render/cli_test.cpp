// `vgeo render` end to end: exit codes, JSON statistics, PNG output, determinism.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "render/frame_loop_flags.h"
#include "render/stream_fixture.h"
#include "vgeo/stream/stream.h"
#include "support/paths.h"
#include "support/run_command.h"

namespace vgeo {
namespace {

using CliRun = test::CliResult;
using test::run_cli;

std::string scene(const char* name) { return (test::source_dir() / "tests" / "scenes" / name).string(); }

TEST(RenderCli, RendersASceneToPngWithJsonStatistics) {
  auto dir = std::filesystem::temp_directory_path() / ("vgeo_render_cli_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::string png = (dir / "frame.png").string();
  CliRun r = run_cli("render " + scene("spheres.json") + " --no-cache --threads 2 --json -o " + png);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto j = nlohmann::json::parse(r.output);
  ASSERT_EQ(j["frames"].size(), 1u);
  EXPECT_GT(j["frames"][0]["triangles_drawn"].get<uint64_t>(), 0u);
  bool has_raster = false;
  for (const auto& p : j["frames"][0]["passes"]) has_raster |= p["name"] == "raster";
  EXPECT_TRUE(has_raster);
  std::ifstream f(png, std::ios::binary);
  char magic[8] = {};
  f.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  std::filesystem::remove_all(dir);
}

TEST(RenderCli, ThreadCountDoesNotChangeTheOutput) {
  CliRun a = run_cli("render " + scene("camera_path.json") + " --no-cache --threads 1 --json --view cluster");
  CliRun b = run_cli("render " + scene("camera_path.json") + " --no-cache --threads 3 --json --view cluster");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  ASSERT_EQ(b.exit_code, 0) << b.output;
  auto ja = nlohmann::json::parse(a.output), jb = nlohmann::json::parse(b.output);
  EXPECT_EQ(ja["vis_hash"], jb["vis_hash"]);
  EXPECT_EQ(ja["image_hash"], jb["image_hash"]);
}

TEST(RenderCli, BadInputGivesOneLineAndStableExitCode) {
  auto dir = std::filesystem::temp_directory_path() / ("vgeo_render_bad_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::string bad = (dir / "bad.json").string();
  std::ofstream(bad) << R"({"version": 1, "meshes": [], "instances": [{"mesh": 0}], "cameras": []})";
  CliRun r = run_cli("render " + bad + " --no-cache");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_EQ(r.output.rfind("error[SCENE_", 0), 0u) << r.output;
  CliRun missing = run_cli("render " + (dir / "missing.json").string());
  EXPECT_EQ(missing.exit_code, 4) << missing.output;
  CliRun view = run_cli("render " + scene("spheres.json") + " --no-cache --view nope");
  EXPECT_EQ(view.exit_code, 2) << view.output;
  std::filesystem::remove_all(dir);
}

// --stream-budget: a bad size is one stable line and exit 2; a budget below the scene's page
// bytes streams (per-frame metrics in --json, PNGs with --out-dir); a scene without page
// files says streaming is off.
TEST(RenderCli, StreamBudget) {
  const test::StreamFixture& f = test::stream_fixture();
  const std::string scene_path = f.dir + "/cli_scene.json";
  std::ofstream(scene_path) << test::stream_scene_json("meshes.vgp", 3, 12, 2, true);
  CliRun bad = run_cli("render " + scene_path + " --stream-budget 64XB");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.output.rfind("error[RENDER_STREAM_BUDGET]", 0), 0u) << bad.output;
  EXPECT_EQ(std::count(bad.output.begin(), bad.output.end(), '\n'), 1);
  CliRun negative = run_cli("render " + scene_path + " --stream-budget 1MiB --disk-latency-ms -1");
  EXPECT_EQ(negative.exit_code, 2);
  EXPECT_NE(negative.output.find("error[RENDER_STREAM_OPTION]"), std::string::npos) << negative.output;
  CliRun pace = run_cli("render " + scene_path + " --stream-budget 1MiB --frame-ms nan");
  EXPECT_EQ(pace.exit_code, 2);
  EXPECT_NE(pace.output.find("error[RENDER_STREAM_OPTION]"), std::string::npos) << pace.output;
  CliRun small = run_cli("render " + scene_path + " --stream-budget 1KiB");
  EXPECT_EQ(small.exit_code, 3);
  EXPECT_NE(small.output.find("error[STREAM_BUDGET_TOO_SMALL]"), std::string::npos) << small.output;

  const uint64_t budget = f.pinned + (f.total - f.pinned) / 3;
  const std::string out_dir = f.dir + "/cli_frames";
  CliRun ok = run_cli("render " + scene_path + " --stream-budget " + std::to_string(budget) +
                      " --stream-sync --frames 10 --threads 2 --json --out-dir " + out_dir + " --save-every 5");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  auto j = nlohmann::json::parse(ok.output);
  EXPECT_TRUE(j["stream_summary"]["active"].get<bool>());
  EXPECT_GT(j["stream_summary"]["bytes_read"].get<uint64_t>(), 0u);
  ASSERT_EQ(j["frames"].size(), 10u);
  for (const auto& fr : j["frames"]) EXPECT_LE(fr["stream"]["reserved_bytes"].get<uint64_t>(), budget);
  EXPECT_TRUE(std::filesystem::exists(out_dir + "/frame_00000.png"));
  EXPECT_TRUE(std::filesystem::exists(out_dir + "/frame_00005.png"));
  EXPECT_TRUE(std::filesystem::exists(out_dir + "/frame_00009.png"));

  CliRun off = run_cli("render " + scene("camera_path.json") + " --no-cache --threads 2 --frames 1 --stream-budget 64MiB");
  ASSERT_EQ(off.exit_code, 0) << off.output;
  EXPECT_EQ(off.output.rfind("streaming: off", 0), 0u) << off.output;
}

// The frame loop's flags (--out-dir/--save-every, --frame-ms, the stream summary) on the
// default backend and on --backend cpu, and one vis_hash for the same frame: both run the one
// frame loop (render/run.h). --backend vulkan: tests/gpu/gpu_cli_test.cpp.
TEST(RenderCli, FrameLoopFlagsOnTheDefaultBackend) {
  EXPECT_FALSE(test::check_frame_loop_flags("", "default").empty());
}

TEST(RenderCli, FrameLoopFlagsOnTheCpuBackendAndTheSameVisHash) {
  const std::string cpu = test::check_frame_loop_flags("--backend cpu", "cpu");
  EXPECT_FALSE(cpu.empty());
  // Before the one loop, the default path printed FNV-1a of the raw keys (16f4a4f2… for the
  // default scene) and --backend cpu the order-independent hash (e7791fdc…) of the same frame.
  CliRun a = run_cli("render " + scene("spheres.json") + " --no-cache --threads 2 --json");
  CliRun b = run_cli("render " + scene("spheres.json") + " --no-cache --threads 2 --json --backend cpu");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  ASSERT_EQ(b.exit_code, 0) << b.output;
  auto ja = nlohmann::json::parse(a.output), jb = nlohmann::json::parse(b.output);
  EXPECT_EQ(ja["vis_hash"], jb["vis_hash"]);
  EXPECT_EQ(ja["cluster_set_hash"], jb["cluster_set_hash"]);
  EXPECT_EQ(ja["image_hash"], jb["image_hash"]);
}

// `vgeo build --page-size`: a bad size is BUILD_PAGE_SIZE (one line, exit 2, checked before
// the input is read); a good one is the written file's page size.
TEST(BuildCli, PageSize) {
  for (const char* bad : {"8KiB", "48KiB", "32MiB", "0", "abc", "-16KiB"}) {
    CliRun r = run_cli(std::string("build missing_input.ply -o /dev/null --page-size ") + bad);
    EXPECT_EQ(r.exit_code, 2) << bad;
    EXPECT_EQ(r.output.rfind("error[BUILD_PAGE_SIZE]", 0), 0u) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  auto dir = std::filesystem::temp_directory_path() / ("vgeo_build_page_size_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string ply = (dir / "s.ply").string(), out = (dir / "s.vgp").string();
  ASSERT_EQ(run_cli("gen sphere -n 3000 -o " + ply).exit_code, 0);
  CliRun ok = run_cli("build " + ply + " -o " + out + " --threads 2 --page-size 16KiB");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_EQ(read_container_metadata(out).page_size, 16u * 1024u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vgeo
