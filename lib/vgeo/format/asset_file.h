#pragma once
// Built-asset files of either container, chosen by magic on read and by extension on write:
//   "VGEOPAGE" — the compressed page format (spec/format.md): what `vgeo build` writes by default;
//   "VGEODAG1" — the simple uncompressed DAG file (spec/dag.md): lossless float positions, the
//                interchange format for other implementations' DAGs (`.vgeodag`).
// `vgeo verify`, `vgeo render` (scene meshes with "dag") and the scene cache read both.
#include <string>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/format/format.h"

namespace vgeo {

enum class AssetFileKind : uint8_t { kPages = 0, kDagFile = 1 };

// The extensions that name each format: a file with neither magic is rejected by the reader
// its extension names. A page file has one extension, `.vgp`, everywhere (spec/format.md), so
// that a junk file is either named as a format or reported as ASSET_FILE_UNKNOWN.
inline constexpr const char* kDagFileExtension = ".vgeodag";
inline constexpr const char* kPageFileExtensions[] = {".vgp"};

// `.vgeodag` → kDagFile; anything else → kPages.
AssetFileKind asset_file_kind_for_path(const std::string& path);

// The reader is chosen by the magic; a file with neither magic goes to the reader its extension
// names (.vgeodag: DAGFILE_BAD_MAGIC, .vgp: FORMAT_BAD_MAGIC). Throws VgeoError: the FILE_* codes
// of read_file (lib/vgeo/core/file_io.h), ASSET_FILE_UNKNOWN (neither magic nor extension,
// exit 3), or the decoder's FORMAT_* / DAGFILE_* code.
BuiltScene read_asset_file(const std::string& path);

// Written atomically (write_file_atomic): an existing file is never left half-written;
// IO_WRITE_FAILED (exit 4) on an I/O failure.
void write_asset_file(const std::string& path, const BuiltScene& scene, AssetFileKind kind,
                      const FormatOptions& options = {}, FormatReport* report = nullptr);

}  // namespace vgeo
