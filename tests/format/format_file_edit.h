#pragma once
// Test helper: recomputes every CRC of a page-format file after a deliberate edit, for
// version 1 (plain metadata) and version 2 (metadata possibly compressed, page table
// byte-transposed; spec/format.md §1.2). A compressed metadata section is re-compressed
// (zstd level 3 / lz4) after the page CRCs are patched, and metadata_size / file_size are
// updated by the size change; if the metadata does not decompress (a deliberately broken
// frame), only the metadata and header CRCs are recomputed.
#include <lz4.h>
#include <zstd.h>

#include <cstdint>
#include <vector>

#include "vgeo/format/crc32c.h"

namespace vgeo::test {

inline uint32_t file_le32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
inline void file_put32(uint8_t* p, uint32_t v) {
  for (int k = 0; k < 4; ++k) p[k] = uint8_t(v >> (8 * k));
}

inline void fix_file_crcs(std::vector<uint8_t>& f) {
  if (f.size() < 64) return;
  const uint32_t version = file_le32(&f[8]), pages = file_le32(&f[32]), meta_size = file_le32(&f[36]);
  if (64 + uint64_t(meta_size) <= f.size()) {
    const uint32_t comp = version >= 2 ? file_le32(&f[48]) : 0;
    const uint32_t raw_size = version >= 2 ? file_le32(&f[44]) : meta_size;
    std::vector<uint8_t> raw(f.begin() + 64, f.begin() + 64 + long(meta_size));
    bool ok = true;
    if (comp == 1 || comp == 2) {
      std::vector<uint8_t> out(raw_size);
      if (comp == 1) {
        const size_t n = ZSTD_decompress(out.data(), out.size(), raw.data(), raw.size());
        ok = !ZSTD_isError(n) && n == raw_size;
      } else {
        const int n = LZ4_decompress_safe(reinterpret_cast<const char*>(raw.data()), reinterpret_cast<char*>(out.data()),
                                          int(raw.size()), int(out.size()));
        ok = n >= 0 && uint32_t(n) == raw_size;
      }
      raw = std::move(out);
    }
    if (ok && raw.size() >= 24 * size_t(pages)) {
      uint8_t* table = raw.data() + raw.size() - 24 * size_t(pages);
      // Byte b of field j (u32) of page entry p.
      auto at = [&](uint32_t p, uint32_t j, uint32_t b) -> uint8_t& {
        return version >= 2 ? table[(4 * j + b) * size_t(pages) + p] : table[24 * size_t(p) + 4 * j + b];
      };
      auto field = [&](uint32_t p, uint32_t j) {
        return uint32_t(at(p, j, 0)) | uint32_t(at(p, j, 1)) << 8 | uint32_t(at(p, j, 2)) << 16 | uint32_t(at(p, j, 3)) << 24;
      };
      uint64_t offset = 64 + uint64_t(meta_size);
      for (uint32_t p = 0; p < pages; ++p) {
        const uint32_t stored = field(p, 1);
        if (offset + stored <= f.size()) {
          const uint32_t crc = crc32c(&f[offset], stored);
          for (uint32_t b = 0; b < 4; ++b) at(p, 5, b) = uint8_t(crc >> (8 * b));
        }
        offset += stored;
      }
      std::vector<uint8_t> meta = raw;
      if (comp == 1) {
        meta.resize(ZSTD_compressBound(raw.size()));
        meta.resize(ZSTD_compress(meta.data(), meta.size(), raw.data(), raw.size(), 3));
      } else if (comp == 2) {
        meta.resize(size_t(LZ4_compressBound(int(raw.size()))));
        meta.resize(size_t(LZ4_compress_default(reinterpret_cast<const char*>(raw.data()), reinterpret_cast<char*>(meta.data()),
                                                int(raw.size()), int(meta.size()))));
      }
      {
        const uint64_t file_size = uint64_t(file_le32(&f[16])) | uint64_t(file_le32(&f[20])) << 32;
        const uint64_t new_size = file_size - meta_size + meta.size();
        f.erase(f.begin() + 64, f.begin() + 64 + long(meta_size));
        f.insert(f.begin() + 64, meta.begin(), meta.end());
        file_put32(&f[36], uint32_t(meta.size()));
        file_put32(&f[16], uint32_t(new_size));
        file_put32(&f[20], uint32_t(new_size >> 32));
      }
    }
    const uint32_t ms = file_le32(&f[36]);
    if (64 + uint64_t(ms) <= f.size()) file_put32(&f[40], crc32c(&f[64], ms));
  }
  file_put32(&f[60], crc32c(&f[0], 60));
}

}  // namespace vgeo::test
