#pragma once
// Simple, uncompressed serialization of a BuiltScene (magic "VGEODAG1", spec/dag.md).
// The distributable page format is lib/vgeo/format (spec/format.md); this one exists so the
// builder and the checker can be used before/without it, and as an interchange format
// other implementations can produce for `vgeo verify`.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/dag/cluster_dag.h"

namespace vgeo {

struct ByteSink;

// The file's first 8 bytes (spec/dag.md §7): "VGEODAG" and the format generation digit.
inline constexpr char kDagFileMagic[8] = {'V', 'G', 'E', 'O', 'D', 'A', 'G', '1'};

std::vector<uint8_t> encode_dag_file(const BuiltScene& scene);
// Throws VgeoError (codes DAGFILE_*) on malformed input; never over-allocates.
BuiltScene decode_dag_file(const uint8_t* data, size_t size, const std::string& where);

// Streams the same bytes as encode_dag_file into `sink` (no whole-file copy in memory).
void write_dag_to(ByteSink& sink, const BuiltScene& scene);
// Atomic (lib/vgeo/core/file_io.h); throws VgeoError IO_WRITE_FAILED on I/O failure.
void write_dag_file(const std::string& path, const BuiltScene& scene);
// Throws the FILE_* codes of read_file or the decoder's DAGFILE_* codes.
BuiltScene read_dag_file(const std::string& path);

}  // namespace vgeo
