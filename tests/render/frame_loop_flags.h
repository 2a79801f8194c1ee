#pragma once
// The frame loop's flags on one backend (`vgeo render` end to end, spec/gpu.md §Backends: every
// option means the same on every backend). Shared by tests/render/cli_test.cpp (the default
// and --backend cpu) and tests/gpu/gpu_cli_test.cpp (--backend vulkan).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "render/stream_fixture.h"
#include "support/run_command.h"

namespace vgeo::test {

// Pacing of the flag test: 3 frames at this interval start ≥ 2 intervals apart in all.
inline constexpr int kFlagTestFrameMs = 400;

// Renders the streamed fly-through's first 3 frames with `backend_args` (e.g. "--backend
// vulkan"), --frame-ms, --out-dir with --save-every 1, the table on stdout and the JSON in a
// file; checks that every flag is honoured: 3 PNGs written, the run took at least the paced
// intervals, the stream summary printed and in the JSON. Returns the last frame's vis_hash
// ("" after a failure).
inline std::string check_frame_loop_flags(const std::string& backend_args, const std::string& tag) {
  const StreamFixture& f = stream_fixture();
  const std::string scene = f.dir + "/flags_" + tag + ".json";
  std::ofstream(scene) << stream_scene_json("meshes.vgp", 3, 12, 2, true);
  const std::string out_dir = f.dir + "/flags_" + tag + "_frames", json_file = f.dir + "/flags_" + tag + ".out.json";
  std::filesystem::remove_all(out_dir);
  const uint64_t budget = f.pinned + (f.total - f.pinned) / 3;
  const auto start = std::chrono::steady_clock::now();
  const CliResult r = run_cli("render '" + scene + "' " + backend_args + " --stream-budget " + std::to_string(budget) +
                              " --stream-sync --frames 3 --threads 2 --frame-ms " + std::to_string(kFlagTestFrameMs) +
                              " --out-dir '" + out_dir + "' --save-every 1 --json-file '" + json_file + "'");
  const auto wall = std::chrono::steady_clock::now() - start;
  EXPECT_EQ(r.exit_code, 0) << tag << ": " << r.output;
  if (r.exit_code != 0) return "";
  for (const char* png : {"frame_00000.png", "frame_00001.png", "frame_00002.png"})
    EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(out_dir) / png)) << tag << ": " << png << " not written";
  EXPECT_GE(wall, std::chrono::milliseconds(2 * kFlagTestFrameMs)) << tag << ": --frame-ms not honoured";
  EXPECT_NE(r.output.find("stream summary: "), std::string::npos) << tag << ": no stream summary\n" << r.output;
  std::ifstream in(json_file);
  EXPECT_TRUE(in) << tag << ": --json-file not written";
  if (!in) return "";
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json j = nlohmann::json::parse(text.str());
  EXPECT_EQ(j["frames"].size(), 3u) << tag;
  EXPECT_TRUE(j["stream_summary"]["active"].get<bool>()) << tag;
  EXPECT_EQ(j["saved_pngs"].size(), 3u) << tag;
  return j["vis_hash"].get<std::string>();
}

}  // namespace vgeo::test
