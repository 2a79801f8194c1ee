#pragma once
// Test helper for the vector generator (format_vectors_test.cpp) and the structure-aware
// tests: field-level edits of a page-format file that keep it parseable up to the planted
// fault. The metadata is walked by the layout of spec/format.md §1.2 (version 2 record arrays
// byte-transposed); an edited metadata is written back uncompressed (metadata_compression 0 —
// a valid encoder choice) and every size and CRC is fixed, so the file fails exactly at the
// planted rule.
#include <cstdint>
#include <algorithm>
#include <functional>
#include <vector>

#include "format_file_edit.h"

namespace vgeo::test {

// Record sizes of spec/format.md §1.2.
inline constexpr uint32_t kMetaInstanceBytes = 68, kMetaMeshHeaderBytes = 68, kMetaClusterBytes = 76,
                          kMetaGroupBytes = 60, kMetaBvhBytes = 76, kMetaPageEntryBytes = 24;

// A fixed-size record array in the raw metadata.
struct MetaArray {
  size_t at = 0;
  uint32_t count = 0, record_size = 0;
  bool transposed = false;
  size_t byte(uint32_t i, uint32_t offset) const {
    return transposed ? at + size_t(offset) * count + i : at + size_t(i) * record_size + offset;
  }
};

struct MetaLayout {
  MetaArray instances, pages;
  size_t page_count_at = 0;
  struct Mesh {
    size_t header_at = 0;  // flags +0, position_step +4, uv_step +8, normal_bits +12, counts +44.., first_page +60, page_count +64
    MetaArray clusters, groups, generated, bvh, page_clusters;
  };
  std::vector<Mesh> meshes;
};

inline uint32_t meta_get32(const std::vector<uint8_t>& raw, const MetaArray& a, uint32_t i, uint32_t offset) {
  uint32_t v = 0;
  for (uint32_t b = 0; b < 4; ++b) v |= uint32_t(raw[a.byte(i, offset + b)]) << (8 * b);
  return v;
}
inline void meta_put32(std::vector<uint8_t>& raw, const MetaArray& a, uint32_t i, uint32_t offset, uint32_t v) {
  for (uint32_t b = 0; b < 4; ++b) raw[a.byte(i, offset + b)] = uint8_t(v >> (8 * b));
}

// Walks a valid raw metadata (no checks: the input is one of our own files).
inline MetaLayout walk_metadata(const std::vector<uint8_t>& m, uint32_t version) {
  MetaLayout L;
  const bool tr = version >= 2;
  size_t at = 0;
  const uint32_t materials = file_le32(&m[at]);
  at += 4;
  for (uint32_t i = 0; i < materials; ++i) at += 4 + file_le32(&m[at]) + 16;
  L.instances = {at + 4, file_le32(&m[at]), kMetaInstanceBytes, tr};
  at += 4 + size_t(L.instances.count) * kMetaInstanceBytes;
  const uint32_t meshes = file_le32(&m[at]);
  at += 4;
  for (uint32_t i = 0; i < meshes; ++i) {
    MetaLayout::Mesh mesh;
    mesh.header_at = at;
    const uint32_t nc = file_le32(&m[at + 44]), ng = file_le32(&m[at + 48]), nge = file_le32(&m[at + 52]),
                   nb = file_le32(&m[at + 56]);
    at += kMetaMeshHeaderBytes;
    mesh.clusters = {at, nc, kMetaClusterBytes, tr};
    at += size_t(nc) * kMetaClusterBytes;
    mesh.groups = {at, ng, kMetaGroupBytes, tr};
    at += size_t(ng) * kMetaGroupBytes;
    mesh.generated = {at, nge, 4, tr};
    at += size_t(nge) * 4;
    mesh.bvh = {at, nb, kMetaBvhBytes, tr};
    at += size_t(nb) * kMetaBvhBytes;
    mesh.page_clusters = {at, nc, 4, tr};
    at += size_t(nc) * 4;
    L.meshes.push_back(mesh);
  }
  L.page_count_at = at;
  L.pages = {at + 4, file_le32(&m[at]), kMetaPageEntryBytes, tr};
  return L;
}

// The raw (decompressed) metadata of a file.
inline std::vector<uint8_t> raw_metadata(const std::vector<uint8_t>& f) {
  const uint32_t version = file_le32(&f[8]), meta_size = file_le32(&f[36]);
  const uint32_t comp = version >= 2 ? file_le32(&f[48]) : 0;
  const uint32_t raw_size = version >= 2 ? file_le32(&f[44]) : meta_size;
  std::vector<uint8_t> stored(f.begin() + 64, f.begin() + 64 + long(meta_size));
  if (comp == 0) return stored;
  std::vector<uint8_t> out(raw_size);
  if (comp == 1) ZSTD_decompress(out.data(), out.size(), stored.data(), stored.size());
  else LZ4_decompress_safe(reinterpret_cast<const char*>(stored.data()), reinterpret_cast<char*>(out.data()),
                           int(stored.size()), int(out.size()));
  return out;
}

using MetadataEdit = std::function<void(std::vector<uint8_t>& raw, const MetaLayout& layout)>;

// Applies `edit` to the raw metadata, stores it back uncompressed (version 2:
// metadata_compression 0, raw size = stored size), moves file_size by the size change and
// recomputes every page CRC (through the page table as laid out before the edit, with the
// stored sizes after it), then the metadata and header CRCs.
inline void edit_metadata(std::vector<uint8_t>& f, const MetadataEdit& edit) {
  const uint32_t version = file_le32(&f[8]), meta_size = file_le32(&f[36]);
  std::vector<uint8_t> raw = raw_metadata(f);
  const MetaLayout L = walk_metadata(raw, version);
  edit(raw, L);
  std::vector<uint8_t> out(f.begin(), f.begin() + 64);
  out.insert(out.end(), raw.begin(), raw.end());
  out.insert(out.end(), f.begin() + 64 + long(meta_size), f.end());
  const uint64_t file_size = uint64_t(file_le32(&f[16])) | uint64_t(file_le32(&f[20])) << 32;
  const uint64_t new_size = file_size - meta_size + raw.size();
  file_put32(&out[16], uint32_t(new_size));
  file_put32(&out[20], uint32_t(new_size >> 32));
  file_put32(&out[36], uint32_t(raw.size()));
  if (version >= 2) {
    file_put32(&out[44], uint32_t(raw.size()));
    file_put32(&out[48], 0);
  }
  uint64_t offset = 64 + raw.size();
  for (uint32_t p = 0; p < L.pages.count; ++p) {
    if (L.pages.byte(p, 23) >= raw.size()) break;  // a shortened table: nothing to fix
    const uint32_t stored = meta_get32(raw, L.pages, p, 4);
    if (offset + stored <= out.size()) meta_put32(raw, L.pages, p, 20, crc32c(&out[offset], stored));
    offset += stored;
  }
  std::copy(raw.begin(), raw.end(), out.begin() + 64);
  file_put32(&out[40], crc32c(raw.data(), raw.size()));
  file_put32(&out[60], crc32c(out.data(), 60));
  f = std::move(out);
}

// File offset of page `p`'s stored bytes.
inline size_t page_offset(const std::vector<uint8_t>& f, uint32_t p) {
  const std::vector<uint8_t> raw = raw_metadata(f);
  const MetaLayout L = walk_metadata(raw, file_le32(&f[8]));
  size_t at = 64 + file_le32(&f[36]);
  for (uint32_t i = 0; i < p; ++i) at += meta_get32(raw, L.pages, i, 4);
  return at;
}

// Replaces page `p`'s stored bytes by what `edit` makes of them, updating stored_size (and
// raw_size when `raw_too`: a file without compression, stored = raw), file_size and every CRC.
inline void edit_raw_page(std::vector<uint8_t>& f, uint32_t p, const std::function<void(std::vector<uint8_t>&)>& edit,
                          bool raw_too = true) {
  const size_t at = page_offset(f, p);
  const std::vector<uint8_t> raw = raw_metadata(f);
  const MetaLayout L = walk_metadata(raw, file_le32(&f[8]));
  const uint32_t old_size = meta_get32(raw, L.pages, p, 4);
  std::vector<uint8_t> page(f.begin() + long(at), f.begin() + long(at + old_size));
  edit(page);
  f.erase(f.begin() + long(at), f.begin() + long(at + old_size));
  f.insert(f.begin() + long(at), page.begin(), page.end());
  const uint64_t file_size = uint64_t(file_le32(&f[16])) | uint64_t(file_le32(&f[20])) << 32;
  const uint64_t new_size = file_size - old_size + page.size();
  file_put32(&f[16], uint32_t(new_size));
  file_put32(&f[20], uint32_t(new_size >> 32));
  edit_metadata(f, [&](std::vector<uint8_t>& m, const MetaLayout& layout) {
    meta_put32(m, layout.pages, p, 4, uint32_t(page.size()));
    if (raw_too) meta_put32(m, layout.pages, p, 8, uint32_t(page.size()));
  });
}

// Offsets inside a raw disk page (spec/format.md §5.2) of cluster headers and sections.
struct RawPageLayout {
  uint32_t n = 0, channels = 0;
  size_t counts = 8, bits = 0, mins = 0, ctl = 0, ref_total = 0, refs = 0, run_start = 0, run_material = 0;
  uint64_t triangles = 0, runs = 0;
};
inline RawPageLayout raw_page_layout(const std::vector<uint8_t>& page, uint32_t channels) {
  RawPageLayout L;
  L.n = file_le32(&page[4]);
  L.channels = channels;
  for (uint32_t i = 0; i < L.n; ++i) L.triangles += page[8 + L.n + i], L.runs += page[8 + 2 * L.n + i];
  L.bits = 8 + 3 * size_t(L.n);
  L.mins = L.bits + size_t(L.n) * channels;
  L.ctl = L.mins + 4 * size_t(L.n) * channels;
  L.ref_total = L.ctl + L.triangles;
  L.refs = L.ref_total + 4;
  L.run_start = L.refs + file_le32(&page[L.ref_total]);
  L.run_material = L.run_start + L.runs;
  return L;
}

}  // namespace vgeo::test
