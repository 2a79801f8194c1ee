// Field-level edits of page-format files (lib/vgeo/format/format_edit.h).
#include "vgeo/format/format_edit.h"

#include <algorithm>

#include "vgeo/core/error.h"
#include "vgeo/format/crc32c.h"
#include "vgeo/format/format.h"
#include "vgeo/format/page_codec.h"

namespace vgeo {

namespace {
constexpr size_t kHeaderBytes = 64;

uint64_t file_size_of(const std::vector<uint8_t>& f) { return uint64_t(le32_at(&f[16])) | uint64_t(le32_at(&f[20])) << 32; }
void set_file_size(std::vector<uint8_t>& f, uint64_t v) {
  put_le32_at(&f[16], uint32_t(v));
  put_le32_at(&f[20], uint32_t(v >> 32));
}
// Header and metadata bounds of a file this module may edit.
bool has_metadata(const std::vector<uint8_t>& f) {
  return f.size() >= kHeaderBytes && kHeaderBytes + uint64_t(le32_at(&f[36])) <= f.size();
}
}  // namespace

uint32_t le32_at(const uint8_t* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }
void put_le32_at(uint8_t* p, uint32_t v) {
  for (int k = 0; k < 4; ++k) p[k] = uint8_t(v >> (8 * k));
}
uint32_t meta_get32(const std::vector<uint8_t>& raw, const MetaArray& a, uint32_t i, uint32_t offset) {
  uint32_t v = 0;
  for (uint32_t b = 0; b < 4; ++b) v |= uint32_t(raw[a.byte(i, offset + b)]) << (8 * b);
  return v;
}
void meta_put32(std::vector<uint8_t>& raw, const MetaArray& a, uint32_t i, uint32_t offset, uint32_t v) {
  for (uint32_t b = 0; b < 4; ++b) raw[a.byte(i, offset + b)] = uint8_t(v >> (8 * b));
}

bool walk_metadata(const std::vector<uint8_t>& m, uint32_t version, MetaLayout* out) {
  MetaLayout L;
  const bool tr = version >= 2;
  uint64_t at = 0;
  auto u32 = [&](uint64_t pos, uint32_t* v) {
    if (pos + 4 > m.size()) return false;
    *v = le32_at(&m[size_t(pos)]);
    return true;
  };
  auto array = [&](uint32_t count, uint32_t size, MetaArray* a) {
    if (at + uint64_t(count) * size > m.size()) return false;
    *a = {size_t(at), count, size, tr};
    at += uint64_t(count) * size;
    return true;
  };
  uint32_t materials = 0, instances = 0, meshes = 0, len = 0;
  if (!u32(at, &materials)) return false;
  at += 4;
  for (uint32_t i = 0; i < materials; ++i) {
    if (!u32(at, &len)) return false;
    at += 4 + uint64_t(len) + 16;
    if (at > m.size()) return false;
  }
  if (!u32(at, &instances)) return false;
  at += 4;
  if (!array(instances, kMetaInstanceBytes, &L.instances) || !u32(at, &meshes)) return false;
  at += 4;
  for (uint32_t i = 0; i < meshes; ++i) {
    MetaLayout::Mesh mesh;
    mesh.header_at = size_t(at);
    uint32_t nc = 0, ng = 0, nge = 0, nb = 0;
    if (!u32(at + 44, &nc) || !u32(at + 48, &ng) || !u32(at + 52, &nge) || !u32(at + 56, &nb)) return false;
    at += kMetaMeshHeaderBytes;
    if (!array(nc, kMetaClusterBytes, &mesh.clusters) || !array(ng, kMetaGroupBytes, &mesh.groups) ||
        !array(nge, 4, &mesh.generated) || !array(nb, kMetaBvhBytes, &mesh.bvh) || !array(nc, 4, &mesh.page_clusters))
      return false;
    L.meshes.push_back(mesh);
  }
  uint32_t pages = 0;
  L.page_count_at = size_t(at);
  if (!u32(at, &pages)) return false;
  at += 4;
  if (!array(pages, kMetaPageEntryBytes, &L.pages)) return false;
  *out = std::move(L);
  return true;
}

bool raw_metadata(const std::vector<uint8_t>& f, std::vector<uint8_t>* raw) {
  if (!has_metadata(f)) return false;
  const uint32_t version = le32_at(&f[8]), meta_size = le32_at(&f[36]);
  const uint32_t comp = version >= 2 ? le32_at(&f[48]) : 0;
  const uint32_t raw_size = version >= 2 ? le32_at(&f[44]) : meta_size;
  const uint8_t* stored = f.data() + kHeaderBytes;
  if (comp == 0) {
    raw->assign(stored, stored + meta_size);
    return true;
  }
  if (comp > uint32_t(Compression::kLz4) || uint64_t(raw_size) > uint64_t(kMaxMetadataRatio) * meta_size) return false;
  raw->assign(raw_size, 0);
  try {
    format_detail::decompress(stored, meta_size, Compression(comp), raw->data(), raw->size(), "<edit>");
  } catch (const VgeoError&) {
    return false;
  }
  return true;
}

void fix_header_crc(std::vector<uint8_t>& f) {
  if (f.size() >= kHeaderBytes) put_le32_at(&f[60], crc32c(f.data(), 60));
}

bool edit_metadata(std::vector<uint8_t>& f, const MetadataEdit& edit) {
  std::vector<uint8_t> raw;
  MetaLayout L;
  if (!raw_metadata(f, &raw)) return false;
  const uint32_t version = le32_at(&f[8]), meta_size = le32_at(&f[36]);
  if (!walk_metadata(raw, version, &L)) return false;
  edit(raw, L);
  std::vector<uint8_t> out(f.begin(), f.begin() + long(kHeaderBytes));
  out.insert(out.end(), raw.begin(), raw.end());
  out.insert(out.end(), f.begin() + long(kHeaderBytes + meta_size), f.end());
  set_file_size(out, file_size_of(f) - meta_size + raw.size());
  put_le32_at(&out[36], uint32_t(raw.size()));
  if (version >= 2) {
    put_le32_at(&out[44], uint32_t(raw.size()));
    put_le32_at(&out[48], 0);
  }
  uint64_t offset = kHeaderBytes + raw.size();
  for (uint32_t p = 0; p < L.pages.count; ++p) {
    if (L.pages.byte(p, 23) >= raw.size()) break;  // a shortened table: nothing to fix
    const uint32_t stored = meta_get32(raw, L.pages, p, 4);
    if (offset + stored <= out.size()) meta_put32(raw, L.pages, p, 20, crc32c(&out[size_t(offset)], stored));
    offset += stored;
  }
  std::copy(raw.begin(), raw.end(), out.begin() + long(kHeaderBytes));
  put_le32_at(&out[40], crc32c(raw.data(), raw.size()));
  fix_header_crc(out);
  f = std::move(out);
  return true;
}

bool edit_stored_metadata(std::vector<uint8_t>& f, const std::function<void(std::vector<uint8_t>&)>& edit) {
  if (!has_metadata(f)) return false;
  const uint32_t meta_size = le32_at(&f[36]);
  std::vector<uint8_t> stored(f.begin() + long(kHeaderBytes), f.begin() + long(kHeaderBytes + meta_size));
  edit(stored);
  f.erase(f.begin() + long(kHeaderBytes), f.begin() + long(kHeaderBytes + meta_size));
  f.insert(f.begin() + long(kHeaderBytes), stored.begin(), stored.end());
  set_file_size(f, file_size_of(f) - meta_size + stored.size());
  put_le32_at(&f[36], uint32_t(stored.size()));
  put_le32_at(&f[40], crc32c(stored.data(), stored.size()));
  fix_header_crc(f);
  return true;
}

void fix_checksums(std::vector<uint8_t>& f) {
  if (f.size() < kHeaderBytes) return;
  if (has_metadata(f)) {
    const uint32_t version = le32_at(&f[8]), meta_size = le32_at(&f[36]);
    const bool stored_raw = version < 2 || le32_at(&f[48]) == 0;
    std::vector<uint8_t> raw(f.begin() + long(kHeaderBytes), f.begin() + long(kHeaderBytes + meta_size));
    MetaLayout L;
    if (stored_raw && walk_metadata(raw, version, &L)) {
      uint64_t offset = kHeaderBytes + meta_size;
      for (uint32_t p = 0; p < L.pages.count; ++p) {
        const uint32_t stored = meta_get32(raw, L.pages, p, 4);
        if (offset + stored > f.size()) break;
        meta_put32(raw, L.pages, p, 20, crc32c(&f[size_t(offset)], stored));
        offset += stored;
      }
      std::copy(raw.begin(), raw.end(), f.begin() + long(kHeaderBytes));
    }
    put_le32_at(&f[40], crc32c(raw.data(), raw.size()));
  }
  fix_header_crc(f);
}

bool page_offset(const std::vector<uint8_t>& f, uint32_t p, size_t* offset) {
  std::vector<uint8_t> raw;
  MetaLayout L;
  if (!raw_metadata(f, &raw) || !walk_metadata(raw, le32_at(&f[8]), &L) || p >= L.pages.count) return false;
  uint64_t at = kHeaderBytes + le32_at(&f[36]);
  for (uint32_t i = 0; i < p; ++i) at += meta_get32(raw, L.pages, i, 4);
  if (at + meta_get32(raw, L.pages, p, 4) > f.size()) return false;
  *offset = size_t(at);
  return true;
}

bool edit_stored_page(std::vector<uint8_t>& f, uint32_t p, const std::function<void(std::vector<uint8_t>&)>& edit,
                      bool raw_too) {
  size_t at = 0;
  std::vector<uint8_t> raw;
  MetaLayout L;
  if (!page_offset(f, p, &at) || !raw_metadata(f, &raw) || !walk_metadata(raw, le32_at(&f[8]), &L)) return false;
  const uint32_t old_size = meta_get32(raw, L.pages, p, 4);
  std::vector<uint8_t> page(f.begin() + long(at), f.begin() + long(at + old_size));
  edit(page);
  f.erase(f.begin() + long(at), f.begin() + long(at + old_size));
  f.insert(f.begin() + long(at), page.begin(), page.end());
  set_file_size(f, file_size_of(f) - old_size + page.size());
  return edit_metadata(f, [&](std::vector<uint8_t>& m, const MetaLayout& layout) {
    meta_put32(m, layout.pages, p, 4, uint32_t(page.size()));
    if (raw_too) meta_put32(m, layout.pages, p, 8, uint32_t(page.size()));
  });
}

bool edit_raw_page(std::vector<uint8_t>& f, uint32_t p, const std::function<void(std::vector<uint8_t>&)>& edit) {
  std::vector<uint8_t> meta;
  MetaLayout L;
  if (!raw_metadata(f, &meta) || !walk_metadata(meta, le32_at(&f[8]), &L) || p >= L.pages.count) return false;
  const Compression c = Compression(le32_at(&f[24]));
  if (c == Compression::kNone) return edit_stored_page(f, p, edit, true);
  if (uint32_t(c) > uint32_t(Compression::kLz4)) return false;
  const uint32_t raw_size = meta_get32(meta, L.pages, p, 8);
  if (raw_size > 2ull * kMaxPageSize) return false;  // allocation bound: the largest raw page (spec/format.md §7)
  bool ok = true;
  uint32_t new_raw = raw_size;
  const bool edited = edit_stored_page(f, p, [&](std::vector<uint8_t>& stored) {
    std::vector<uint8_t> page(raw_size);
    try {
      format_detail::decompress(stored.data(), stored.size(), c, page.data(), page.size(), "<edit>");
    } catch (const VgeoError&) {
      ok = false;
      return;
    }
    edit(page);
    new_raw = uint32_t(page.size());
    // Level 3: the edit's point is the raw bytes, not the ratio.
    stored = format_detail::compress(page, c, 3);
  }, false);
  if (!edited || !ok) return false;
  if (new_raw == raw_size) return true;
  return edit_metadata(f, [&](std::vector<uint8_t>& m, const MetaLayout& layout) { meta_put32(m, layout.pages, p, 8, new_raw); });
}

bool raw_page_layout(const std::vector<uint8_t>& page, uint32_t channels, RawPageLayout* out) {
  RawPageLayout L;
  if (page.size() < 8) return false;
  L.n = le32_at(&page[4]);
  L.channels = channels;
  if (8 + 3ull * L.n > page.size()) return false;
  for (uint32_t i = 0; i < L.n; ++i) L.triangles += page[8 + L.n + i], L.runs += page[8 + 2 * size_t(L.n) + i];
  L.bits = 8 + 3 * size_t(L.n);
  L.mins = L.bits + size_t(L.n) * channels;
  L.ctl = L.mins + 4 * size_t(L.n) * channels;
  L.ref_total = size_t(L.ctl + L.triangles);
  if (L.ref_total + 4 > page.size()) return false;
  L.refs = L.ref_total + 4;
  L.run_start = L.refs + le32_at(&page[L.ref_total]);
  L.run_material = size_t(L.run_start + L.runs);
  if (L.run_material + 4 * L.runs > page.size()) return false;
  *out = L;
  return true;
}

}  // namespace vgeo
