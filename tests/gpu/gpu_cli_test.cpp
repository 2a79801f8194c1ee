// `vgeo render --backend/--compare/--device/--validate` end to end (spec/gpu.md §Backends).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include "render/frame_loop_flags.h"
#include "render/stream_fixture.h"
#include "support/run_command.h"

namespace vgeo {
namespace {

const std::string kScene = std::string(VGEO_SOURCE_DIR) + "/tests/scenes/far_away.json";

TEST(GpuCli, CompareCpuHoldsWithValidationAndReportsHashes) {
  test::CliResult r = test::run_cli("render '" + kScene + "' --compare cpu --validate --json --no-cache");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["backend"], "vulkan");
  EXPECT_TRUE(j["rule_holds"].get<bool>());
  EXPECT_EQ(j["validation_messages"].get<int>(), 0);
  EXPECT_EQ(j["compare_cpu"][0]["vis_pixels_differing"].get<int>(), 0);
  EXPECT_EQ(j["vis_hash"].get<std::string>().size(), 16u);
  // The CPU backend renders the same decoded memory form: the same hashes.
  test::CliResult c = test::run_cli("render '" + kScene + "' --backend cpu --json --no-cache");
  ASSERT_EQ(c.exit_code, 0) << c.output;
  nlohmann::json k = nlohmann::json::parse(c.output);
  EXPECT_EQ(k["vis_hash"], j["vis_hash"]);
  EXPECT_EQ(k["cluster_set_hash"], j["cluster_set_hash"]);
}

// The frame loop's flags on --backend vulkan (render/frame_loop_flags.h: PNGs with --out-dir
// --save-every 1, --frame-ms pacing, the stream summary; before the one loop the first two
// were ignored and the summary not printed), and the same vis_hash as the CPU for the same
// frames (--stream-sync: both load the same pages).
TEST(GpuCli, FrameLoopFlagsOnTheVulkanBackendAndTheCpuVisHash) {
  const std::string vulkan = test::check_frame_loop_flags("--backend vulkan", "vulkan");
  const std::string cpu = test::check_frame_loop_flags("--backend cpu", "vulkan_cpu");
  EXPECT_FALSE(vulkan.empty());
  EXPECT_EQ(vulkan, cpu);
}

TEST(GpuCli, UnknownDeviceIsAOneLineCodedError) {
  test::CliResult r = test::run_cli("render '" + kScene + "' --backend vulkan --device no-such-gpu --no-cache");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("error[GPU_DEVICE_NOT_FOUND]"), std::string::npos) << r.output;
}

// A validation layer whose manifest is found but whose library does not load (seen where the
// layer's package was unpacked off the library path) is as unavailable as a missing layer.
TEST(GpuCli, ValidationLayerThatDoesNotLoadIsACodedError) {
  // One folder per process: a suite of another tree running at the same time writes its own.
  const std::string dir = testing::TempDir() + "vgeo_broken_layer_" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/VkLayer_khronos_validation.json")
      << R"({"file_format_version": "1.2.0", "layer": {"name": "VK_LAYER_KHRONOS_validation",
           "type": "GLOBAL", "library_path": "./libvgeo_no_such_layer.so", "api_version": "1.3.239",
           "implementation_version": "1", "description": "a manifest without its library"}})";
  test::CliResult r = test::run_command("VK_LAYER_PATH='" + dir + "' '" + test::cli_path() + "' render '" + kScene +
                                        "' --backend vulkan --validate --no-cache");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("error[GPU_VALIDATION_UNAVAILABLE]"), std::string::npos) << r.output;
  std::filesystem::remove_all(dir);
}

// spec/shadow.md: a scene with lights renders on Vulkan; --compare cpu covers the shadow pages
// (page tables and pool texels bit-identical) and the shaded image (the rule).
TEST(GpuCli, SceneWithLightsComparesShadowPagesAndImage) {
  for (const char* name : {"directional.json", "spot.json", "point.json"}) {
    const std::string scene = std::string(VGEO_SOURCE_DIR) + "/tests/shadow/scenes/" + name;
    test::CliResult r = test::run_cli("render '" + scene + "' --backend vulkan --compare cpu --no-cache");
    EXPECT_EQ(r.exit_code, 0) << name << "\n" << r.output;
    EXPECT_NE(r.output.find("compare cpu, shadow pages: 1 frame(s); page tables equal; pool texels differing 0"),
              std::string::npos)
        << name << "\n" << r.output;
    EXPECT_NE(r.output.find("rule holds"), std::string::npos) << name << "\n" << r.output;
  }
}

TEST(GpuCli, CompareNeedsTheVulkanBackend) {
  test::CliResult r = test::run_cli("render '" + kScene + "' --backend cpu --compare cpu --no-cache");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("error[RENDER_BAD_OPTION]"), std::string::npos) << r.output;
}

// Streaming on the Vulkan backend (spec/gpu.md §Streaming): the fly-through streams on both
// backends (--compare forces the deterministic loader), pages go through the GPU pool and the
// rule holds on every frame.
TEST(GpuCli, StreamBudgetCompareHoldsTheRule) {
  const test::StreamFixture& f = test::stream_fixture();
  const std::string scene = f.dir + "/gpu_cli_stream.json";
  std::ofstream(scene) << test::stream_scene_json("meshes.vgp", 3, 12, 2, true);
  const uint64_t budget = f.pinned + (f.total - f.pinned) / 4;
  test::CliResult r = test::run_cli("render '" + scene + "' --stream-budget " + std::to_string(budget) +
                                    " --backend vulkan --compare cpu --validate --json --threads 2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_TRUE(j["rule_holds"].get<bool>());
  ASSERT_EQ(j["frames"].size(), 9u);
  for (const auto& fr : j["frames"]) EXPECT_LE(fr["stream"]["resident_bytes"].get<uint64_t>(), budget);
  EXPECT_GT(j["gpu_page_pool"]["pages_uploaded"].get<uint64_t>(), 0u);
  EXPECT_EQ(j["validation_messages"].get<int>(), 0);
}

// spec/shadow.md §8, §9: a lit scene streams on Vulkan as on the CPU: every frame of the path
// runs the shadow steps (the unshaded ones too: a history and streaming are present), the
// shadow views draw the resident cut (provisional pages, lower-priority requests) from the
// device page pool, and the page tables, counters and pool texels equal the CPU's on every frame.
TEST(GpuCli, StreamedLitSceneComparesShadowPagesOnEveryFrame) {
  const test::StreamFixture& f = test::stream_fixture();
  const std::string scene = f.dir + "/gpu_cli_stream_lit.json";
  std::string json = test::stream_scene_json("meshes.vgp", 3, 12, 2, true);
  json.insert(json.rfind('}'), ",\"lights\":[{\"type\":\"spot\",\"position\":[3,6,2],\"direction\":[-0.4,-1,-0.5],"
                               "\"cone_degrees\":100}]");
  std::ofstream(scene) << json;
  const uint64_t budget = f.pinned + (f.total - f.pinned) / 4;
  test::CliResult r = test::run_cli("render '" + scene + "' --stream-budget " + std::to_string(budget) +
                                    " --backend vulkan --compare cpu --validate --json --threads 2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_TRUE(j.at("rule_holds").get<bool>());
  ASSERT_EQ(j.at("frames").size(), 9u);
  ASSERT_EQ(j.at("compare_cpu").size(), 9u);
  uint64_t loaded = 0, drawn_later = 0, coarser = 0;
  for (size_t k = 0; k < 9; ++k) {
    const nlohmann::json& fr = j.at("frames").at(k);
    ASSERT_TRUE(fr.contains("shadow")) << "frame " << k;
    EXPECT_GT(fr.at("shadow").at("pages_marked").get<uint64_t>(), 0u) << "frame " << k;
    EXPECT_LE(fr.at("stream").at("resident_bytes").get<uint64_t>(), budget) << "frame " << k;
    loaded += fr.at("stream").at("pages_loaded").get<uint64_t>();
    coarser += fr.at("stream").at("clusters_coarser").get<uint64_t>();
    if (k) drawn_later += fr.at("shadow").at("pages_drawn").get<uint64_t>();
    const nlohmann::json& c = j.at("compare_cpu").at(k);
    EXPECT_TRUE(c.at("shadow_tables_equal").get<bool>()) << "frame " << k;
    EXPECT_EQ(c.at("shadow_texels_differing").get<uint64_t>(), 0u) << "frame " << k;
  }
  EXPECT_GT(loaded, 0u);       // pages streamed in along the path
  EXPECT_GT(coarser, 0u);      // some frame drew a coarser cut than ideal (the budget binds)
  EXPECT_GT(drawn_later, 0u);  // later frames drew shadow pages too (not only the first)
  EXPECT_EQ(j.at("validation_messages").get<int>(), 0);
  // The hardware page raster on the same streamed frames, held to the shadow-page hardware rule
  // (its models read the reference's streamed geometry: the scene's meshes are metadata only;
  // reading them crashed the comparison before).
  test::CliResult hw = test::run_cli("render '" + scene + "' --stream-budget " + std::to_string(budget) +
                                     " --backend vulkan --compare cpu --raster hw --threads 2");
  ASSERT_EQ(hw.exit_code, 0) << hw.output;
  EXPECT_NE(hw.output.find("compare cpu, shadow pages (hardware rule): 9 frame(s)"), std::string::npos) << hw.output;
  EXPECT_NE(hw.output.find("depth_beyond_tolerance 0, violation 0"), std::string::npos) << hw.output;
  EXPECT_NE(hw.output.find("rule holds"), std::string::npos) << hw.output;
}

// The compute rasterizer's loop budget (spec/raster.md §13.5): the fly-through's last camera
// at 640×360 has triangles with pixel bounding boxes far beyond it (before the check, lavapipe
// silently drew 71,574 of 160,595 pixels; then --raster sw failed with GPU_SCENE_TOO_LARGE).
// The tile pass draws them: --raster sw keeps bit identity with the CPU; auto sends those
// clusters to the hardware path and keeps the hardware rule.
TEST(GpuCli, ComputeRasterDrawsTrianglesBeyondTheLoopBudgetByTiles) {
  const test::StreamFixture& f = test::stream_fixture();
  const std::string scene = f.dir + "/gpu_cli_near.json";
  std::ofstream(scene) << "{\"version\":1,\"meshes\":[{\"dag\":\"meshes.vgp\",\"index\":0},{\"dag\":\"meshes.vgp\","
                          "\"index\":1}],\"instances\":[{\"mesh\":0,\"translation\":[-1.5,0,0]},{\"mesh\":1,"
                          "\"translation\":[0,0,-2.5]},{\"mesh\":0,\"translation\":[1.5,0,-5]}],\"cameras\":[{\"position\":"
                          "[2.5,0.4,-5],\"look_at\":[0,0,-7.5],\"resolution\":[640,360]}],\"settings\":{\"occlusion\":true}}";
  test::CliResult sw =
      test::run_cli("render '" + scene + "' --backend vulkan --compare cpu --raster sw --tau 1000 --json --threads 2");
  ASSERT_EQ(sw.exit_code, 0) << sw.output;
  nlohmann::json s = nlohmann::json::parse(sw.output);
  EXPECT_TRUE(s["rule_holds"].get<bool>());
  EXPECT_EQ(s["compare_cpu"][0]["vis_pixels_differing"].get<int>(), 0);
  const nlohmann::json& split = s["frames"].back()["raster_split"];
  // Not vacuous: triangles over the loop budget were drawn, by tiles.
  EXPECT_GT(split["sw_tiled_triangles"].get<uint64_t>(), 0u);
  EXPECT_GT(split["sw_tiles"].get<uint64_t>(), split["sw_tiled_triangles"].get<uint64_t>());
  test::CliResult aut =
      test::run_cli("render '" + scene + "' --backend vulkan --compare cpu --raster auto --tau 1000 --json --threads 2");
  ASSERT_EQ(aut.exit_code, 0) << aut.output;
  nlohmann::json j = nlohmann::json::parse(aut.output);
  EXPECT_TRUE(j["rule_holds"].get<bool>());
  EXPECT_GT(j["frames"].back()["raster_split"]["hw_clusters"].get<uint64_t>(), 0u);
}

TEST(GpuCli, RasterHwKeepsTheHardwareRuleAndCountsItsClusters) {
  test::CliResult r = test::run_cli("render '" + kScene + "' --compare cpu --raster hw --validate --json --no-cache");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["raster"], "hw");
  EXPECT_TRUE(j["rule_holds"].get<bool>());
  const nlohmann::json& split = j["frames"].back()["raster_split"];
  EXPECT_EQ(split["sw_clusters"].get<int>(), 0);
  EXPECT_EQ(split["hw_clusters"].get<uint64_t>(), j["frames"].back()["clusters_drawn"].get<uint64_t>());
  const nlohmann::json& rule = j["compare_cpu"][0]["hw_rule"];
  EXPECT_EQ(rule["violation"].get<int>(), 0);
  EXPECT_EQ(rule["depth_beyond_tolerance"].get<int>(), 0);
}

TEST(GpuCli, BadRasterModeIsACodedError) {
  for (const char* args : {" --backend vulkan --raster fast", " --backend cpu --raster hw"}) {
    test::CliResult r = test::run_cli("render '" + kScene + "'" + args + " --no-cache");
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.output;
    EXPECT_NE(r.output.find("error[RENDER_BAD_OPTION]"), std::string::npos) << r.output;
  }
}

}  // namespace
}  // namespace vgeo
