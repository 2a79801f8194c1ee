#include "vgeo/format/asset_file.h"

#include <cstring>
#include <filesystem>
#include <vector>

#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/dag/dag_io.h"

namespace vgeo {

AssetFileKind asset_file_kind_for_path(const std::string& path) {
  return std::filesystem::path(path).extension() == kDagFileExtension ? AssetFileKind::kDagFile : AssetFileKind::kPages;
}

BuiltScene read_asset_file(const std::string& path) {
  // Page files and DAG files may exceed 4 GiB: the allocation is the file's own size.
  std::vector<uint8_t> bytes = read_file(path, kAnyFileSize);
  if (bytes.size() >= 8 && std::memcmp(bytes.data(), kPageFileMagic, 8) == 0)
    return decode_format(bytes.data(), bytes.size(), path);
  // "VGEODAG" + version digit: the DAG decoder reports a wrong digit as DAGFILE_BAD_VERSION.
  if (bytes.size() >= 7 && std::memcmp(bytes.data(), kDagFileMagic, 7) == 0)
    return decode_dag_file(bytes.data(), bytes.size(), path);
  // Neither magic: a file named as one of the two formats is that format's reader's to reject
  // (one reader, one code: DAGFILE_BAD_MAGIC / FORMAT_BAD_MAGIC, as the vectors' manifests and
  // `vgeo conform hash` say); any other name is not an asset file.
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == kDagFileExtension) return decode_dag_file(bytes.data(), bytes.size(), path);
  for (const char* page_ext : kPageFileExtensions)
    if (ext == page_ext) return decode_format(bytes.data(), bytes.size(), path);
  fail("ASSET_FILE_UNKNOWN", path, "neither a page-format file (VGEOPAGE) nor a DAG file (VGEODAG1)");
}

void write_asset_file(const std::string& path, const BuiltScene& scene, AssetFileKind kind,
                      const FormatOptions& options, FormatReport* report) {
  if (kind == AssetFileKind::kDagFile) {
    write_dag_file(path, scene);  // streamed: no in-memory copy of a multi-GB DAG
    return;
  }
  // Streamed: the pages go to the file as they are, never copied into one buffer first.
  write_file_atomic(path, [&](ByteSink& sink) { encode_format(scene, options, sink, report); });
}

}  // namespace vgeo
