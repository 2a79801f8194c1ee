// Replays every file under tests/regressions/scene/ through the reader its fuzz target drives
// (names are <fuzz target>-<what it found>.json: camera_path → load_camera_path_file,
// scene_json → load_scene_file). Each once crashed; it must now load or be refused with a code.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "support/paths.h"
#include "vgeo/core/error.h"
#include "vgeo/render/scene_file.h"

namespace {

TEST(SceneRegressions, EveryRegressionFileLoadsOrIsRefusedWithACode) {
  const auto dir = vgeo::test::source_dir() / "tests" / "regressions" / "scene";
  ASSERT_TRUE(std::filesystem::is_directory(dir));
  int replayed = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    SCOPED_TRACE(name);
    try {
      if (name.rfind("camera_path-", 0) == 0) {
        (void)vgeo::load_camera_path_file(entry.path().string(), vgeo::Camera{});
      } else {
        ASSERT_EQ(name.rfind("scene_json-", 0), 0u) << "unknown regression target prefix";
        (void)vgeo::load_scene_file(entry.path().string(), vgeo::SceneLoadOptions{});
      }
    } catch (const vgeo::VgeoError& e) {
      EXPECT_FALSE(e.error().code.empty()) << e.what();
      EXPECT_EQ(e.error().exit_code, vgeo::kExitBadInput) << e.what();
    }
    ++replayed;
  }
  EXPECT_GT(replayed, 0);
}

}  // namespace
