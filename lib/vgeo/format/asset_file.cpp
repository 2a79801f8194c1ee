#include "vgeo/format/asset_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <vector>

#include "vgeo/dag/dag_io.h"
#include "vgeo/core/error.h"
#include "vgeo/mesh/export.h"

namespace vgeo {
namespace {

constexpr char kPageMagic[8] = {'V', 'G', 'E', 'O', 'P', 'A', 'G', 'E'};
constexpr char kDagMagic[8] = {'V', 'G', 'E', 'O', 'D', 'A', 'G', '1'};

std::vector<uint8_t> read_whole_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    fail("ASSET_FILE_IO", path, "not a readable regular file", kExitIo);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail("ASSET_FILE_IO", path, std::string("cannot open: ") + std::strerror(errno), kExitIo);
  std::vector<uint8_t> bytes;
  // The allocation is the file's size as the file system reports it (bounded by the input).
  bytes.resize(size_t(std::filesystem::file_size(path, ec)));
  size_t got = ec ? 0 : std::fread(bytes.data(), 1, bytes.size(), f);
  bool failed = ec || std::ferror(f) || got != bytes.size() || std::fgetc(f) != EOF;
  std::fclose(f);
  if (failed) fail("ASSET_FILE_IO", path, "read failed or the file changed while reading", kExitIo);
  return bytes;
}

}  // namespace

AssetFileKind asset_file_kind_for_path(const std::string& path) {
  return std::filesystem::path(path).extension() == ".vgeodag" ? AssetFileKind::kDagFile : AssetFileKind::kPages;
}

BuiltScene read_asset_file(const std::string& path) {
  std::vector<uint8_t> bytes = read_whole_file(path);
  if (bytes.size() >= 8 && std::memcmp(bytes.data(), kPageMagic, 8) == 0)
    return decode_format(bytes.data(), bytes.size(), path);
  // "VGEODAG" + version digit: the DAG decoder reports a wrong digit as DAGFILE_BAD_VERSION.
  if (bytes.size() >= 7 && std::memcmp(bytes.data(), kDagMagic, 7) == 0)
    return decode_dag_file(bytes.data(), bytes.size(), path);
  fail("ASSET_FILE_UNKNOWN", path, "neither a page-format file (VGEOPAGE) nor a DAG file (VGEODAG1)");
}

void write_asset_file(const std::string& path, const BuiltScene& scene, AssetFileKind kind,
                      const FormatOptions& options, FormatReport* report) {
  if (kind == AssetFileKind::kDagFile) {
    write_dag_file(path, scene);  // streamed: no in-memory copy of a multi-GB DAG
    return;
  }
  std::vector<uint8_t> bytes = encode_format(scene, options, report);
  write_file_atomic(path, bytes.data(), bytes.size());
}

}  // namespace vgeo
