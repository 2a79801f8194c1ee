// Replays every file under tests/regressions/mesh/ through the importer (import_scene, the
// path `vgeo info` takes). Names are <fuzz target>-<what it found>.<ext>: each file once
// crashed, hung or was refused without a code (OpenMesh's readers, fuzzing, tools/mutate-inputs)
// and must now import or be refused with a VgeoError code from spec/errors.md.
#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>

#include "support/paths.h"
#include "vgeo/mesh/import.h"

namespace {

bool is_error_code(const std::string& code) {
  if (code.empty()) return false;
  for (char c : code)
    if (!(std::isupper(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '_')) return false;
  return true;
}

TEST(ImportRegressions, EveryRegressionFileImportsOrIsRefusedWithACode) {
  const auto dir = vgeo::test::source_dir() / "tests" / "regressions" / "mesh";
  ASSERT_TRUE(std::filesystem::is_directory(dir));
  int replayed = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    SCOPED_TRACE(entry.path().filename().string());
    try {
      const vgeo::ImportResult r = vgeo::import_scene(entry.path().string());
      EXPECT_FALSE(r.scene.meshes.empty());
    } catch (const vgeo::VgeoError& e) {
      EXPECT_TRUE(is_error_code(e.error().code)) << e.what();
      EXPECT_EQ(e.error().exit_code, vgeo::kExitBadInput) << e.what();
    }
    ++replayed;
  }
  EXPECT_GT(replayed, 0);
}

}  // namespace
