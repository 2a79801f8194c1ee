// CRC-32C, table driven. Based on: Castagnoli, Bräuer, Herrmann, "Optimization of Cyclic
// Redundancy-Check Codes with 24 and 32 Parity Bits", IEEE Trans. Commun. 41(6), 1993; the
// check value of RFC 3720 §B.4. Eight bytes a step by slicing (Kounavis, Berry, "A Systematic
// Approach to Building High Performance Software-Based CRC Generators", ISCC 2005): the same
// CRC as the byte-at-a-time table, ~4x fewer dependent table lookups (the page CRCs were ~1.7%
// of the write stage on a 1M-triangle sphere).
#include "vgeo/format/crc32c.h"

#include <array>

namespace vgeo {
namespace {

constexpr uint32_t kCrc32cPolynomial = 0x82F63B78u;  // reflected Castagnoli polynomial

constexpr std::array<uint32_t, 256> make_table() {
  std::array<uint32_t, 256> table{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? (c >> 1) ^ kCrc32cPolynomial : c >> 1;
    table[i] = c;
  }
  return table;
}
constexpr std::array<uint32_t, 256> kTable = make_table();

// kSlices[k][i]: the CRC of byte i followed by k zero bytes (kSlices[0] = kTable).
constexpr int kSliceBytes = 8;
constexpr std::array<std::array<uint32_t, 256>, kSliceBytes> make_slices() {
  std::array<std::array<uint32_t, 256>, kSliceBytes> t{};
  t[0] = kTable;
  for (int k = 1; k < kSliceBytes; ++k)
    for (uint32_t i = 0; i < 256; ++i) t[k][i] = (t[k - 1][i] >> 8) ^ kTable[t[k - 1][i] & 0xFFu];
  return t;
}
constexpr std::array<std::array<uint32_t, 256>, kSliceBytes> kSlices = make_slices();

uint32_t le32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

}  // namespace

uint32_t crc32c(const void* data, size_t size, uint32_t crc) {
  const auto* p = static_cast<const uint8_t*>(data);
  uint32_t c = ~crc;
  for (; size >= kSliceBytes; size -= kSliceBytes, p += kSliceBytes) {
    const uint32_t lo = c ^ le32(p), hi = le32(p + 4);
    c = kSlices[7][lo & 0xFFu] ^ kSlices[6][(lo >> 8) & 0xFFu] ^ kSlices[5][(lo >> 16) & 0xFFu] ^ kSlices[4][lo >> 24] ^
        kSlices[3][hi & 0xFFu] ^ kSlices[2][(hi >> 8) & 0xFFu] ^ kSlices[1][(hi >> 16) & 0xFFu] ^ kSlices[0][hi >> 24];
  }
  for (size_t i = 0; i < size; ++i) c = kTable[(c ^ p[i]) & 0xFFu] ^ (c >> 8);
  return ~c;
}

}  // namespace vgeo
