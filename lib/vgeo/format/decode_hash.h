#pragma once
// The canonical decode hash of spec/format.md §9 (the `OK <hash>` of spec/vectors/manifest.txt
// and the protocol of spec/conform.md §5): FNV-1a 64 over, per mesh in order, the decoded
// positions, normals, uvs (float32 bits, little-endian), indices (u8) and triangle materials
// (u32 little-endian), in cluster-index order. Little-endian hosts (as the decoder).
#include <cstdint>

#include "vgeo/core/hash.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/format/format.h"

namespace vgeo {

inline uint64_t decode_hash(const BuiltScene& s) {
  uint64_t h = kFnvOffset;
  for (const ClusterDag& d : s.meshes) {
    h = fnv1a64(d.positions.data(), d.positions.size() * 4, h);
    h = fnv1a64(d.normals.data(), d.normals.size() * 4, h);
    h = fnv1a64(d.uvs.data(), d.uvs.size() * 4, h);
    h = fnv1a64(d.indices.data(), d.indices.size(), h);
    h = fnv1a64(d.triangle_materials.data(), d.triangle_materials.size() * 4, h);
  }
  return h;
}

// The memory-form hash of spec/format.md §9 (`memory=` in the manifest): FNV-1a 64, one
// stream over every page's transcoded memory form (memory_size bytes, words little-endian)
// in page-table order. Throws the decoder's FORMAT_* codes (the container, each page).
inline uint64_t memory_form_hash(const uint8_t* data, size_t size, const std::string& where) {
  const FormatContainer fc = parse_container(data, size, where);
  if (size < fc.file_size) fail(kErrTruncated, where, "file shorter than its declared size");
  if (size > fc.file_size) fail(kErrTrailingBytes, where, "bytes after the last page");
  uint64_t h = kFnvOffset;
  for (uint32_t p = 0; p < fc.pages.size(); ++p) {
    const std::vector<uint32_t> words = transcode_page(fc, p, data + fc.pages[p].file_offset, fc.pages[p].stored_size, where);
    h = fnv1a64(words.data(), words.size() * 4, h);
  }
  return h;
}

}  // namespace vgeo
