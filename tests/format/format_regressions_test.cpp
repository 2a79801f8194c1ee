// Replays every file under tests/regressions/format/ through the fuzz entry point named by
// its prefix (<target>-<what-it-found>): each file once crashed a fuzz target and must now
// be handled (accepted or rejected with a FORMAT_* code) without a crash or sanitizer error.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "../../fuzz/format_entries.h"
#include "support/paths.h"

namespace vgeo {
namespace {

TEST(FormatRegressions, EveryRegressionFileIsHandled) {
  const auto dir = test::source_dir() / "tests" / "regressions" / "format";
  ASSERT_TRUE(std::filesystem::is_directory(dir));
  int replayed = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    std::ifstream in(entry.path(), std::ios::binary);
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    SCOPED_TRACE(name);
    const std::string target = name.substr(0, name.find('-'));
    if (target == "container") fuzz::container_entry(bytes.data(), bytes.size());
    else if (target == "page_transcode") fuzz::page_transcode_entry(bytes.data(), bytes.size());
    else if (target == "memory_decode") fuzz::memory_decode_entry(bytes.data(), bytes.size());
    else if (target == "roundtrip") fuzz::roundtrip_entry(bytes.data(), bytes.size());
    else if (target == "gltf_import") continue;  // replayed by the importer's tests
    else ADD_FAILURE() << "unknown fuzz target prefix in " << name;
    ++replayed;
  }
  EXPECT_GT(replayed, 0);
}

}  // namespace
}  // namespace vgeo
