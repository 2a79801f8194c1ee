// CRC-32C, table driven. Based on: Castagnoli, Bräuer, Herrmann, "Optimization of Cyclic
// Redundancy-Check Codes with 24 and 32 Parity Bits", IEEE Trans. Commun. 41(6), 1993; the
// check value of RFC 3720 §B.4.
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

}  // namespace

uint32_t crc32c(const void* data, size_t size, uint32_t crc) {
  const auto* p = static_cast<const uint8_t*>(data);
  uint32_t c = ~crc;
  for (size_t i = 0; i < size; ++i) c = kTable[(c ^ p[i]) & 0xFFu] ^ (c >> 8);
  return ~c;
}

}  // namespace vgeo
