#pragma once
// Where tests find inputs: the source tree, the git-ignored data/ cache filled by
// tools/fetch-data, and the built `vgeo` executable.
#include <filesystem>
#include <string>

namespace vgeo::test {

inline std::filesystem::path source_dir() { return VGEO_SOURCE_DIR; }
inline std::filesystem::path data_dir() { return VGEO_DATA_DIR; }
inline std::string cli_path() { return VGEO_CLI; }

}  // namespace vgeo::test
