// `vgeo conform lod|decoder|hash ...`: conformance runs of another implementation against vgeo's vectors
// (spec/conform.md). Each subcommand lives in its own cmd_conform_*.cpp.
#include "conform.h"

#include <filesystem>

#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"

namespace vgeo::cli {

std::vector<uint8_t> read_conform_file(const std::string& path, uint64_t max_bytes, const std::string& what) {
  try {
    return read_file(path, max_bytes);
  } catch (const VgeoError& e) {
    fail("CONFORM_IO", path, "cannot read " + what + " (" + e.error().code + ": " + e.error().what + ")", e.error().exit_code);
  }
}

std::string read_conform_text(const std::string& path, const std::string& what) {
  const std::vector<uint8_t> bytes = read_conform_file(path, kMaxConformTextBytes, what);
  return std::string(bytes.begin(), bytes.end());
}

std::string resolve_vectors_dir(const std::string& given, const std::string& relative, const std::string& marker) {
  namespace fs = std::filesystem;
  if (!given.empty()) return given;
  std::error_code ec;
  if (fs::exists(fs::path(relative) / marker, ec)) return relative;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    for (fs::path dir = exe.parent_path(); !dir.empty(); dir = dir.parent_path()) {
      if (fs::exists(dir / relative / marker, ec)) return (dir / relative).string();
      if (dir == dir.root_path()) break;
    }
  fail("CONFORM_USAGE", "--vectors",
       "no " + relative + "/" + marker + " in the working directory or above the vgeo binary; give --vectors DIR "
       "(the repository's " + relative + ")",
       kExitUsage);
}

void add_conform_command(CLI::App& app, Context& ctx) {
  auto* cmd = app.add_subcommand("conform", "check another implementation against vgeo's conformance vectors");
  cmd->require_subcommand(1);
  add_conform_lod_command(*cmd, ctx);
  add_conform_decoder_command(*cmd, ctx);
}

}  // namespace vgeo::cli
